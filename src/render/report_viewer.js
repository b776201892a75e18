// shapemap report viewer: the interactive 3D views of report.html (include/shapemap/render/
// report_viewer.h). Reads window.SHAPEMAP_VIEWER (report_data.js: settings + base64 buffers),
// draws with three.js r111 (global THREE, three.min.js beside the page). Two linked views:
// one rotation / zoom / pan drives both cameras, each framed on its own shape.
// Plain script, no modules, no fetch: it runs from file:// with no server.
(function () {
  'use strict';
  var host = document.getElementById('views');
  var D = window.SHAPEMAP_VIEWER;
  window.SHAPEMAP_VIEWER_FRAMES = 0;
  function fail(msg) {
    if (host) host.innerHTML = '<p style="color:#a00">3D views unavailable: ' + msg + '</p>';
    window.SHAPEMAP_VIEWER_STATUS = 'error: ' + msg;
  }
  if (!host) return;
  if (typeof THREE === 'undefined') return fail('three.min.js is missing beside report.html (Debian: libjs-three); the pictures below still show the map.');
  if (!D) return fail('report_data.js is missing beside report.html.');

  // ---- binary buffers (little-endian float32 / uint32 / uint8, base64) --------------------
  var cache = {};
  function buf(name) {
    if (cache[name]) return cache[name];
    var L = D.layout[name];
    if (!L) return null;
    var s = atob(D.buffers[name]), n = s.length, u8 = new Uint8Array(n);
    for (var i = 0; i < n; ++i) u8[i] = s.charCodeAt(i);
    var a = L.type === 'f32' ? new Float32Array(u8.buffer) : L.type === 'u32' ? new Uint32Array(u8.buffer) : u8;
    return (cache[name] = a);
  }
  function rows(name) { return D.layout[name] ? D.layout[name].rows : 0; }

  // ---- page layout: toolbar, one canvas with two viewports, label overlay, legend ---------
  var bar = document.createElement('div');
  bar.style.cssText = 'margin:4px 0;font-size:13px';
  var wrap = document.createElement('div');
  wrap.style.cssText = 'position:relative;border:1px solid #ddd';
  var overlay = document.createElement('div');
  overlay.style.cssText = 'position:absolute;left:0;top:0;right:0;bottom:0;pointer-events:none;overflow:hidden;font:12px sans-serif';
  var legend = document.createElement('div');
  legend.style.cssText = 'font-size:13px;margin:4px 0';
  var help = document.createElement('div');
  help.style.cssText = 'font-size:12px;color:#666';
  help.textContent = 'Drag: rotate both views. Right-drag or shift-drag: pan. Wheel: zoom. Double-click: reset.';
  host.appendChild(bar);
  host.appendChild(wrap);
  host.appendChild(legend);
  host.appendChild(help);

  // Multisampling only for small meshes: on a CPU WebGL (SwiftShader) it costs a second or
  // more on the first frame of a 100k-triangle pair (bench/report_viewer.py).
  var triangles = 0;
  for (var name in D.layout) if (/^[FT]_/.test(name)) triangles += D.layout[name].rows;
  var renderer;
  try {
    renderer = new THREE.WebGLRenderer({antialias: triangles < 60000, preserveDrawingBuffer: true});
  } catch (e) {
    return fail('WebGL is not available (' + e.message + ').');
  }
  renderer.setPixelRatio(window.devicePixelRatio || 1);
  renderer.setScissorTest(true);
  renderer.domElement.id = 'viewer-canvas';
  renderer.domElement.style.display = 'block';
  wrap.appendChild(renderer.domElement);
  wrap.appendChild(overlay);

  // ---- linked cameras -------------------------------------------------------------------
  var state = {q: new THREE.Quaternion(), zoom: 1, pan: new THREE.Vector2(0, 0)};
  function resetView() {
    // A three-quarter view from the front (+z), slightly above.
    state.q.setFromEuler(new THREE.Euler(-0.35, 0.5, 0, 'YXZ'));
    state.zoom = 1;
    state.pan.set(0, 0);
  }
  resetView();
  var views = [];  // {scene, camera, center, radius, title, labels: [{p, text, color}]}
  function makeView(bbox, title) {
    var lo = new THREE.Vector3().fromArray(bbox.min), hi = new THREE.Vector3().fromArray(bbox.max);
    var v = {scene: new THREE.Scene(), camera: new THREE.PerspectiveCamera(30, 1, 0.01, 100),
             center: lo.clone().add(hi).multiplyScalar(0.5), radius: Math.max(1e-9, hi.distanceTo(lo) / 2),
             title: title, labels: []};
    v.scene.background = new THREE.Color(1, 1, 1);
    views.push(v);
    return v;
  }
  function placeCamera(v, aspect) {
    var up = new THREE.Vector3(0, 1, 0).applyQuaternion(state.q);
    var right = new THREE.Vector3(1, 0, 0).applyQuaternion(state.q);
    var back = new THREE.Vector3(0, 0, 1).applyQuaternion(state.q);
    var dist = v.radius / Math.sin(THREE.Math.degToRad(15)) * 1.05 * state.zoom;
    var target = v.center.clone().addScaledVector(right, state.pan.x * v.radius).addScaledVector(up, state.pan.y * v.radius);
    v.camera.aspect = aspect;
    v.camera.near = dist * 0.02;
    v.camera.far = dist * 10;
    v.camera.position.copy(target).addScaledVector(back, dist);
    v.camera.up.copy(up);
    v.camera.lookAt(target);
    v.camera.updateProjectionMatrix();
  }

  var W = 0, H = 0, pending = 0;  // pending: the id of the requested animation frame
  function resize() {
    W = Math.max(300, host.clientWidth || 800);
    H = Math.round(Math.min(620, Math.max(260, W * 0.5)));
    renderer.setSize(W, H);
    wrap.style.height = H + 'px';
    // Now, not on the next animation frame: browsers hold those back in hidden tabs and in
    // iframes out of view (the demo's index), and the page should show its views at once.
    render();
  }
  function draw() {
    if (!pending) pending = requestAnimationFrame(render);
  }
  var labelDivs = [];
  function render() {
    // A frame drawn now makes a requested one redundant (each costs ~0.3 s at 100k triangles
    // on SwiftShader).
    if (pending) cancelAnimationFrame(pending);
    pending = 0;
    var n = views.length, w = Math.floor(W / n), used = 0;
    for (var i = 0; i < n; ++i) {
      var v = views[i];
      placeCamera(v, w / H);
      renderer.setViewport(i * w, 0, w, H);
      renderer.setScissor(i * w, 0, w, H);
      renderer.render(v.scene, v.camera);
      // Titles and numbered points as HTML over the canvas.
      var items = [{x: 6, y: 4, text: v.title, color: '#222', title: true}];
      for (var k = 0; k < v.labels.length; ++k) {
        var p = v.labels[k].p.clone().project(v.camera);
        if (p.z > 1) continue;
        items.push({x: i * w + (p.x + 1) / 2 * w + 4, y: (1 - p.y) / 2 * H - 14, text: v.labels[k].text,
                    color: v.labels[k].color});
      }
      for (var j = 0; j < items.length; ++j, ++used) {
        if (!labelDivs[used]) {
          labelDivs[used] = document.createElement('div');
          labelDivs[used].style.position = 'absolute';
          overlay.appendChild(labelDivs[used]);
        }
        var d = labelDivs[used], it = items[j];
        d.style.display = 'block';
        d.style.left = (it.title ? i * w + it.x : it.x) + 'px';
        d.style.top = it.y + 'px';
        d.style.color = it.color;
        d.style.fontWeight = it.title ? 'bold' : 'normal';
        d.style.background = it.title ? 'rgba(255,255,255,0.7)' : 'none';
        d.textContent = it.text;
      }
    }
    for (; used < labelDivs.length; ++used) labelDivs[used].style.display = 'none';
    // ms from the start of the page's navigation to the first drawn frame (bench/report_viewer.py).
    if (!window.SHAPEMAP_VIEWER_FRAMES) window.SHAPEMAP_VIEWER_FIRST_DRAW_MS = performance.now();
    window.SHAPEMAP_VIEWER_FRAMES++;
    window.SHAPEMAP_VIEWER_STATUS = 'drawn';
  }

  // ---- rotate / zoom / pan (our own small orbit control, shared by both views) ----------
  var canvas = renderer.domElement, drag = null;
  canvas.addEventListener('contextmenu', function (e) { e.preventDefault(); });
  canvas.addEventListener('pointerdown', function (e) {
    drag = {x: e.clientX, y: e.clientY, pan: e.button === 2 || e.shiftKey};
    if (canvas.setPointerCapture) canvas.setPointerCapture(e.pointerId);
  });
  canvas.addEventListener('pointermove', function (e) {
    if (!drag) return;
    var dx = e.clientX - drag.x, dy = e.clientY - drag.y;
    drag.x = e.clientX;
    drag.y = e.clientY;
    if (drag.pan) {
      var s = 2.1 * state.zoom / H;  // the view's height spans about 2.1 radii
      state.pan.x -= dx * s;
      state.pan.y += dy * s;
    } else {
      // Trackball-like: horizontal drag turns about the screen's vertical axis, vertical drag
      // about its horizontal axis (both in the current camera frame).
      var up = new THREE.Vector3(0, 1, 0).applyQuaternion(state.q);
      var right = new THREE.Vector3(1, 0, 0).applyQuaternion(state.q);
      state.q.premultiply(new THREE.Quaternion().setFromAxisAngle(up, -dx * 0.008));
      state.q.premultiply(new THREE.Quaternion().setFromAxisAngle(right, -dy * 0.008));
      state.q.normalize();
    }
    draw();
  });
  canvas.addEventListener('pointerup', function () { drag = null; });
  canvas.addEventListener('wheel', function (e) {
    e.preventDefault();
    state.zoom = Math.min(20, Math.max(0.05, state.zoom * Math.exp(e.deltaY * 0.001)));
    draw();
  }, {passive: false});
  canvas.addEventListener('dblclick', function () { resetView(); draw(); });
  window.addEventListener('resize', resize);

  // ---- materials ------------------------------------------------------------------------
  var LIGHT = 'float shade(vec3 n) { return 0.35 + 0.65 * abs(dot(normalize(n), normalize(vec3(0.4, 0.6, 1.0)))); }\n';
  // Surfaces: colour from a 3D point `tex` (the target's own position, or the image of a
  // source vertex): a colour field of the normalized position times a checkerboard.
  function textureMaterial(bbox) {
    var lo = new THREE.Vector3().fromArray(bbox.min), hi = new THREE.Vector3().fromArray(bbox.max);
    var size = Math.max(hi.x - lo.x, hi.y - lo.y, hi.z - lo.z, 1e-12);
    return new THREE.ShaderMaterial({
      uniforms: {lo: {value: lo}, size: {value: size}, cells: {value: 8.0}, checker: {value: 1.0}},
      side: THREE.DoubleSide,
      polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1,
      vertexShader: 'attribute vec3 tex; varying vec3 vN; varying vec3 vT;\n' +
        'void main() { vN = normalMatrix * normal; vT = tex; gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0); }',
      fragmentShader: 'uniform vec3 lo; uniform float size; uniform float cells; uniform float checker;\n' +
        'varying vec3 vN; varying vec3 vT;\n' + LIGHT +
        'void main() { vec3 p = clamp((vT - lo) / size, 0.0, 1.0); vec3 base = 0.2 + 0.75 * p;\n' +
        '  vec3 c = floor((vT - lo) / size * cells); float odd = mod(c.x + c.y + c.z, 2.0);\n' +
        '  vec3 col = mix(base, base * (odd > 0.5 ? 1.0 : 0.4), checker);\n' +
        '  gl_FragColor = vec4(col * shade(vN), 1.0); }'
    });
  }
  // Per-vertex error against the ground truth: blue 0, red >= errMax, grey where unknown (< 0).
  function errorMaterial(errMax) {
    return new THREE.ShaderMaterial({
      uniforms: {errMax: {value: Math.max(errMax, 1e-12)}},
      side: THREE.DoubleSide,
      polygonOffset: true, polygonOffsetFactor: 1, polygonOffsetUnits: 1,
      vertexShader: 'attribute float err; varying vec3 vN; varying float vE;\n' +
        'void main() { vN = normalMatrix * normal; vE = err; gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0); }',
      fragmentShader: 'uniform float errMax; varying vec3 vN; varying float vE;\n' + LIGHT +
        'void main() { float t = clamp(vE / errMax, 0.0, 1.0);\n' +
        '  vec3 col = vE < 0.0 ? vec3(0.7) : (t < 0.5 ? mix(vec3(0.15, 0.3, 0.9), vec3(1.0, 0.95, 0.3), 2.0 * t)\n' +
        '                                           : mix(vec3(1.0, 0.95, 0.3), vec3(0.85, 0.1, 0.1), 2.0 * t - 1.0));\n' +
        '  gl_FragColor = vec4(col * shade(vN), 1.0); }'
    });
  }
  // Per-vertex colours (the volume cuts: one colour per face).
  var colorMaterial = new THREE.ShaderMaterial({
    side: THREE.DoubleSide,
    vertexShader: 'attribute vec3 col; varying vec3 vN; varying vec3 vC;\n' +
      'void main() { vN = normalMatrix * normal; vC = col; gl_Position = projectionMatrix * modelViewMatrix * vec4(position, 1.0); }',
    fragmentShader: 'varying vec3 vN; varying vec3 vC;\n' + LIGHT +
      'void main() { gl_FragColor = vec4(vC * shade(vN), 1.0); }'
  });
  var ghostMaterial = new THREE.MeshBasicMaterial({color: 0x8899aa, transparent: true, opacity: 0.12,
                                                   depthWrite: false, side: THREE.DoubleSide});

  function el(tag, text) { var e = document.createElement(tag); if (text) e.textContent = text; return e; }
  function addControl(label, control) {
    var l = el('label', label + ' ');
    l.style.marginRight = '1em';
    l.appendChild(control);
    bar.appendChild(l);
    return control;
  }
  function select(options) {
    var s = el('select');
    options.forEach(function (o) { var op = el('option', o[1]); op.value = o[0]; s.appendChild(op); });
    return s;
  }
  function clearScene(v) {
    for (var i = v.scene.children.length - 1; i >= 0; --i) {
      var c = v.scene.children[i];
      if (c.geometry && !c.userData.keep) c.geometry.dispose();
      v.scene.remove(c);
    }
    v.labels = [];
  }

  // ---- surface maps ---------------------------------------------------------------------
  function surfaceGeometry(V, F, tex) {
    var g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(V, 3));
    g.setAttribute('tex', new THREE.BufferAttribute(tex, 3));
    g.setIndex(new THREE.BufferAttribute(F, 1));
    g.computeVertexNormals();
    return g;
  }
  function subsetMesh(V, F, flags, value, color) {
    var idx = [];
    for (var f = 0; f < flags.length; ++f)
      if (flags[f] === value) idx.push(F[3 * f], F[3 * f + 1], F[3 * f + 2]);
    if (!idx.length) return null;
    var g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(V, 3));
    g.setIndex(idx);
    return new THREE.Mesh(g, new THREE.MeshBasicMaterial({color: color, side: THREE.DoubleSide}));
  }
  function points(list, color) {
    var g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.Float32BufferAttribute(list, 3));
    return new THREE.Points(g, new THREE.PointsMaterial({color: color, size: 9, sizeAttenuation: false, depthTest: false}));
  }
  function surfaceViewer() {
    var M = D.meta, dirs = M.directions;
    var left = makeView(M.bbox_B, ''), right = makeView(M.bbox_A, '');
    var side = {A: {V: buf('V_A'), F: buf('F_A'), bbox: M.bbox_A}, B: {V: buf('V_B'), F: buf('F_B'), bbox: M.bbox_B}};
    var dirSel = dirs.length > 1 ? addControl('map', select(dirs.map(function (d) {
      return [d.tag, d.tag === 'AB' ? 'A \u2192 B (map_AB)' : 'B \u2192 A (map_BA)'];
    }))) : null;
    var modes = [['1', 'checkerboard \u00d7 colour'], ['0', 'colour field']];
    if (D.layout.err_AB) modes.push(['e', 'A: error vs ground truth']);
    var modeSel = addControl('texture', select(modes));
    function build() {
      var tag = dirSel ? dirSel.value : 'AB';
      var d = dirs.filter(function (x) { return x.tag === tag; })[0];
      var S = tag === 'AB' ? side.A : side.B, T = tag === 'AB' ? side.B : side.A;
      var sName = tag === 'AB' ? 'A' : 'B', tName = tag === 'AB' ? 'B' : 'A';
      var X = buf('X_' + tag);
      [left, right].forEach(clearScene);
      // Target and source views are framed on their own shapes.
      var lo = new THREE.Vector3().fromArray(T.bbox.min), hi = new THREE.Vector3().fromArray(T.bbox.max);
      left.center = lo.clone().add(hi).multiplyScalar(0.5); left.radius = hi.distanceTo(lo) / 2;
      lo.fromArray(S.bbox.min); hi.fromArray(S.bbox.max);
      right.center = lo.clone().add(hi).multiplyScalar(0.5); right.radius = hi.distanceTo(lo) / 2;
      left.title = tName + ' (target): colour field of its positions';
      right.title = sName + ' (source): ' + tName + "'s field pulled back through map_" + tag;
      var mat = textureMaterial(T.bbox), err = modeSel.value === 'e' ? buf('err_' + tag) : null;
      mat.uniforms.checker.value = modeSel.value === '0' ? 0 : 1;
      left.scene.add(new THREE.Mesh(surfaceGeometry(T.V, T.F, T.V), mat));
      var src = surfaceGeometry(S.V, S.F, X);
      if (err) src.setAttribute('err', new THREE.BufferAttribute(err, 1));
      right.scene.add(new THREE.Mesh(src, err ? errorMaterial(d.error_p95) : mat));
      var flags = buf('flags_' + tag);
      var text = 'map_' + tag + ': ' + d.flipped + ' flipped (red), ' + d.collapsed + ' collapsed (magenta) triangles of ' + sName + '.';
      if (err) {
        right.title = sName + ': geodesic error of map_' + tag + ' vs the ground truth';
        text += ' Error per vertex (geodesic distance / sqrt(area)): blue 0, yellow ' + (d.error_p95 / 2).toPrecision(2) +
          ', red \u2265 ' + d.error_p95.toPrecision(2) + ' (95th percentile; max ' + d.error_max.toPrecision(2) + '); grey: not evaluated.';
      } else if (modeSel.value === 'e') {
        text += ' (The ground-truth error is of map_AB only.)';
      }
      if (flags) {
        var fm = subsetMesh(S.V, S.F, flags, 1, 0xdd0000), cm = subsetMesh(S.V, S.F, flags, 2, 0xdd00dd);
        if (fm) right.scene.add(fm);
        if (cm) right.scene.add(cm);
      }
      // Landmarks: numbered on both shapes; on the target, a line from each landmark to the
      // image of its partner (its length is the map's error there).
      var lm = M.landmarks || [];
      if (lm.length) {
        var sp = [], tp = [], ip = [], seg = [];
        lm.forEach(function (pair, k) {
          var s = tag === 'AB' ? pair[0] : pair[1], t = tag === 'AB' ? pair[1] : pair[0];
          var ps = new THREE.Vector3(S.V[3 * s], S.V[3 * s + 1], S.V[3 * s + 2]);
          var pt = new THREE.Vector3(T.V[3 * t], T.V[3 * t + 1], T.V[3 * t + 2]);
          var pi = new THREE.Vector3(X[3 * s], X[3 * s + 1], X[3 * s + 2]);
          sp.push(ps.x, ps.y, ps.z); tp.push(pt.x, pt.y, pt.z); ip.push(pi.x, pi.y, pi.z);
          seg.push(pt.x, pt.y, pt.z, pi.x, pi.y, pi.z);
          right.labels.push({p: ps, text: String(k + 1), color: '#0040c0'});
          left.labels.push({p: pt, text: String(k + 1), color: '#0040c0'});
        });
        right.scene.add(points(sp, 0x0040c0));
        left.scene.add(points(tp, 0x0040c0));
        left.scene.add(points(ip, 0xff8800));
        var g = new THREE.BufferGeometry();
        g.setAttribute('position', new THREE.Float32BufferAttribute(seg, 3));
        left.scene.add(new THREE.LineSegments(g, new THREE.LineBasicMaterial({color: 0xff8800, depthTest: false})));
        text += ' Landmarks: blue, numbered; orange: the images of ' + sName + "'s landmarks, joined to their partners.";
      }
      legend.textContent = text;
      draw();
    }
    if (dirSel) dirSel.addEventListener('change', build);
    modeSel.addEventListener('change', build);
    build();
  }

  // ---- volume and ball maps: a cut through the source and the same tets at their images ----
  // Tet faces (opposite each corner) and the tet across each one (-1: boundary), found by
  // sorting the faces by their vertex triple.
  function tetNeighbours(T, n) {
    var m = T.length / 4, order = new Uint32Array(4 * m), nb = new Int32Array(4 * m).fill(-1);
    // Numeric keys are exact while n^3 < 2^53 (n < 208k vertices); strings beyond.
    var keys = n < 200000 ? new Float64Array(4 * m) : new Array(4 * m);
    for (var t = 0; t < m; ++t)
      for (var k = 0; k < 4; ++k) {
        var a = T[4 * t + (k + 1) % 4], b = T[4 * t + (k + 2) % 4], c = T[4 * t + (k + 3) % 4], x;
        if (a > b) { x = a; a = b; b = x; }
        if (b > c) { x = b; b = c; c = x; }
        if (a > b) { x = a; a = b; b = x; }
        keys[4 * t + k] = n < 200000 ? (a * n + b) * n + c : a + ',' + b + ',' + c;
        order[4 * t + k] = 4 * t + k;
      }
    order.sort(function (i, j) { return keys[i] < keys[j] ? -1 : keys[i] > keys[j] ? 1 : 0; });
    for (var i = 0; i + 1 < order.length; ++i)
      if (keys[order[i]] === keys[order[i + 1]]) {
        nb[order[i]] = order[i + 1] >> 2;
        nb[order[i + 1]] = order[i] >> 2;
      }
    return nb;
  }
  // Triangles (flat normals, one colour each) of the faces of `keep` tets not shared with
  // another kept tet, at positions P.
  function cutGeometry(T, nb, keep, P, colors) {
    var tri = [];
    for (var t = 0; t < keep.length; ++t) {
      if (!keep[t]) continue;
      for (var k = 0; k < 4; ++k) {
        var o = nb[4 * t + k];
        if (o < 0 || !keep[o]) tri.push(t, k);
      }
    }
    var nt = tri.length / 2, pos = new Float32Array(9 * nt), nor = new Float32Array(9 * nt), col = new Float32Array(9 * nt);
    var a = new THREE.Vector3(), b = new THREE.Vector3(), c = new THREE.Vector3();
    for (var f = 0; f < nt; ++f) {
      var tt = tri[2 * f], kk = tri[2 * f + 1];
      var ids = [T[4 * tt + (kk + 1) % 4], T[4 * tt + (kk + 2) % 4], T[4 * tt + (kk + 3) % 4]];
      for (var j = 0; j < 3; ++j)
        for (var d = 0; d < 3; ++d) {
          pos[9 * f + 3 * j + d] = P[3 * ids[j] + d];
          col[9 * f + 3 * j + d] = colors[3 * tt + d];
        }
      a.fromArray(pos, 9 * f); b.fromArray(pos, 9 * f + 3); c.fromArray(pos, 9 * f + 6);
      b.sub(a); c.sub(a); b.cross(c).normalize();
      for (var j2 = 0; j2 < 3; ++j2) b.toArray(nor, 9 * f + 3 * j2);
    }
    var g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(pos, 3));
    g.setAttribute('normal', new THREE.BufferAttribute(nor, 3));
    g.setAttribute('col', new THREE.BufferAttribute(col, 3));
    return g;
  }
  function boundaryGhost(T, nb, P) {
    var idx = [];
    for (var i = 0; i < nb.length; ++i)
      if (nb[i] < 0) {
        var t = i >> 2, k = i & 3;
        idx.push(T[4 * t + (k + 1) % 4], T[4 * t + (k + 2) % 4], T[4 * t + (k + 3) % 4]);
      }
    var g = new THREE.BufferGeometry();
    g.setAttribute('position', new THREE.BufferAttribute(P, 3));
    g.setIndex(idx);
    return g;
  }
  var VIRIDIS = [[0.267, 0.005, 0.329], [0.229, 0.322, 0.546], [0.128, 0.567, 0.551], [0.369, 0.789, 0.383], [0.993, 0.906, 0.144]];
  function viridis(t) {
    t = Math.min(1, Math.max(0, t)) * (VIRIDIS.length - 1);
    var i = Math.min(VIRIDIS.length - 2, Math.floor(t)), f = t - i;
    return [0, 1, 2].map(function (d) { return VIRIDIS[i][d] * (1 - f) + VIRIDIS[i + 1][d] * f; });
  }
  function tetColors(scalar, bad, info, kind) {
    var m = scalar.length, col = new Float32Array(3 * m);
    var lo = info.scalar_p05, hi = info.scalar_p95;
    for (var t = 0; t < m; ++t) {
      var c;
      if (bad[t]) c = [0.9, 0.05, 0.05];
      else if (kind === 'ball') c = viridis(hi > lo ? (scalar[t] - lo) / (hi - lo) : 0.5);
      else {
        // det J on a log scale: blue compressed, white 1, orange expanded (x4 saturates).
        var s = Math.max(-1, Math.min(1, Math.log2(scalar[t]) / 2));
        c = s < 0 ? [1 + 0.8 * s, 1 + 0.5 * s, 1] : [1, 1 - 0.4 * s, 1 - 0.9 * s];
      }
      col[3 * t] = c[0]; col[3 * t + 1] = c[1]; col[3 * t + 2] = c[2];
    }
    return col;
  }
  function volumeViewer() {
    var M = D.meta, dirs = M.directions, kind = M.kind;
    var left = makeView(M.bbox_A, ''), right = makeView(dirs[0].image_bbox, '');
    var mesh = {A: {V: buf('V_A'), T: buf('T_A'), bbox: M.bbox_A}};
    if (D.layout.V_B) mesh.B = {V: buf('V_B'), T: buf('T_B'), bbox: M.bbox_B};
    var nbs = {};
    function neighbours(name) {
      if (!nbs[name]) nbs[name] = tetNeighbours(mesh[name].T, mesh[name].V.length / 3);
      return nbs[name];
    }
    var dirSel = dirs.length > 1 ? addControl('map', select(dirs.map(function (d) {
      return [d.tag, d.tag === 'AB' ? 'A \u2192 B (X12)' : 'B \u2192 A (X21)'];
    }))) : null;
    var axisSel = addControl('cut normal', select([['2', 'z'], ['0', 'x'], ['1', 'y']]));
    var slider = el('input');
    slider.type = 'range'; slider.min = 0; slider.max = 1000; slider.value = 500; slider.id = 'viewer-cut';
    addControl('cut position', slider);
    var flip = el('input');
    flip.type = 'checkbox';
    addControl('keep other side', flip);
    var colorCache = {};
    function build() {
      var tag = dirSel ? dirSel.value : 'AB';
      var d = dirs.filter(function (x) { return x.tag === tag; })[0];
      var sName = tag === 'AB' ? 'A' : 'B', tName = tag === 'AB' ? 'B' : 'A';
      var S = mesh[sName], X = buf('X_' + tag), nb = neighbours(sName);
      var scalar = buf('scalar_' + tag), bad = buf('bad_' + tag);
      if (!colorCache[tag]) colorCache[tag] = tetColors(scalar, bad, d, kind);
      var axis = +axisSel.value, lo = S.bbox.min[axis], hi = S.bbox.max[axis];
      var cut = lo + (hi - lo) * (+slider.value / 1000), other = flip.checked;
      var m = S.T.length / 4, keep = new Uint8Array(m), V = S.V, T = S.T;
      for (var t = 0; t < m; ++t) {
        var c = (V[3 * T[4 * t] + axis] + V[3 * T[4 * t + 1] + axis] + V[3 * T[4 * t + 2] + axis] + V[3 * T[4 * t + 3] + axis]) / 4;
        keep[t] = other ? c >= cut : c <= cut;
      }
      [left, right].forEach(clearScene);
      var lb = S.bbox, rb = d.image_bbox;
      left.center = new THREE.Vector3().fromArray(lb.min).add(new THREE.Vector3().fromArray(lb.max)).multiplyScalar(0.5);
      left.radius = new THREE.Vector3().fromArray(lb.min).distanceTo(new THREE.Vector3().fromArray(lb.max)) / 2;
      right.center = new THREE.Vector3().fromArray(rb.min).add(new THREE.Vector3().fromArray(rb.max)).multiplyScalar(0.5);
      right.radius = new THREE.Vector3().fromArray(rb.min).distanceTo(new THREE.Vector3().fromArray(rb.max)) / 2;
      left.scene.add(new THREE.Mesh(cutGeometry(T, nb, keep, V, colorCache[tag]), colorMaterial));
      right.scene.add(new THREE.Mesh(cutGeometry(T, nb, keep, X, colorCache[tag]), colorMaterial));
      left.scene.add(new THREE.Mesh(boundaryGhost(T, nb, V), ghostMaterial));
      if (mesh[tName]) right.scene.add(new THREE.Mesh(boundaryGhost(mesh[tName].T, neighbours(tName), mesh[tName].V), ghostMaterial));
      else if (kind === 'ball') right.scene.add(new THREE.Mesh(new THREE.SphereBufferGeometry(1, 48, 24), ghostMaterial));
      if (kind === 'ball') {
        left.title = 'input, cut';
        right.title = 'its ball, the same tets';
        legend.textContent = 'Colour: volume distortion D_V per tet, dark = ' + d.scalar_p05.toPrecision(3) +
          ' (5th percentile) to yellow = ' + d.scalar_p95.toPrecision(3) + ' (95th); red: ' + d.bad + ' folded tets.';
      } else {
        left.title = sName + ', cut';
        right.title = 'its image in ' + tName + ' (X' + (tag === 'AB' ? '12' : '21') + ')';
        legend.textContent = 'Colour: det J per tet, blue < 1 (compressed), white = 1, orange > 1 (expanded, x4 saturates); red: ' +
          d.bad + ' inverted tets (det J \u2264 0). Grey: the boundary of ' + (mesh[tName] ? tName : 'the image') + '.';
      }
      draw();
    }
    [axisSel, flip].concat(dirSel ? [dirSel] : []).forEach(function (c) { c.addEventListener('change', build); });
    slider.addEventListener('input', build);
    build();
  }

  try {
    if (D.meta.kind === 'surface') surfaceViewer();
    else volumeViewer();
    resize();
  } catch (e) {
    fail(e.message);
    throw e;
  }
})();
