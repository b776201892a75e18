#!/usr/bin/env bash
# bench/ball.sh: quality and speed of the ball-shaped volume-preserving parameterization
# (issue 6; isovolumetric-ball-parameterization.txt, Algorithm 1) measured against the
# issue's targets, through the command-line tool:
#   - generated creatures (`generate --shape creature --tets`), --seeds seeds;
#   - spot.obj tetrahedralized (`ball --split-chords`), if ../shared/data/spot.obj exists;
#   - speed: the spot mesh with 500 iterations and tolerance 0 (time per iteration, split);
#   - with --real: the other surfaces in ../shared/data given to `ball X --tets 30000`.
# Prints a markdown table (also written to WORK/ball.md): vertices, tets, E_I after VSEM and
# at the end, folded tets, mean / p50 / p95 of D_V (Eq. 45), boundary distance to the unit
# sphere, share of the ball covered twice, wall seconds; then how many rows meet each target
# (0 folded, mean D_V <= 0.03, E_I final <= E_I after VSEM / 2, boundary <= 1e-9).
#
# Usage: bench/ball.sh [--seeds N] [--vertices N] [--tet-count N] [--spot-tets N] [--real]
#                      [--max-iterations N] [--build DIR] [--work DIR]
#   defaults: 8 seeds, 8000 surface vertices and 40000 tets requested (about 7k vertices /
#   33k tets after meshing), spot 42000 tets (about 7.2k vertices), the paper's 500 CG
#   iterations for the quality rows (--max-iterations; the tolerance 1e-6 can stop them
#   earlier; the speed row always runs 500 with tolerance 0),
#   build/, bench/out/ball.
# A full run takes about 3 minutes on 2 cores (6 more with --real). Exit 1 if a step failed.
set -uo pipefail

ROOT="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
BUILD_DIR="${BUILD:-$ROOT/build}"
SEEDS=8
VERTS=8000
TETS=40000
SPOT_TETS=42000
REAL=0
ITERS=500
WORK="$ROOT/bench/out/ball"
DATA="${SHAPEMAP_DATA:-$ROOT/../shared/data}"

die() { echo "bench/ball.sh: $*" >&2; exit 2; }
while [ $# -gt 0 ]; do
  case "$1" in
    --seeds) SEEDS="${2:?}"; shift ;;
    --vertices) VERTS="${2:?}"; shift ;;
    --tet-count) TETS="${2:?}"; shift ;;
    --spot-tets) SPOT_TETS="${2:?}"; shift ;;
    --real) REAL=1 ;;
    --max-iterations) ITERS="${2:?}"; shift ;;
    --build) BUILD_DIR="${2:?}"; shift ;;
    --work) WORK="${2:?}"; shift ;;
    -h|--help) sed -n '2,21p' "${BASH_SOURCE[0]}"; exit 0 ;;
    *) die "unknown option $1 (see --help)" ;;
  esac
  shift
done
BIN="$BUILD_DIR/shapemap"
UTIL="$BUILD_DIR/tool_bench_util"
[ -x "$BIN" ] || die "$BIN not found (run make build first)"
if [ ! -x "$UTIL" ]; then
  cmake -S "$ROOT" -B "$BUILD_DIR" -DSHAPEMAP_BENCH=ON >/dev/null && cmake --build "$BUILD_DIR" --target tool_bench_util >&2 ||
    die "could not build tool_bench_util"
fi
mkdir -p "$WORK"
OUT="$WORK/ball.md"
LOG="$WORK/log.txt"
: >"$LOG"

FAILED=0
now() { date +%s.%N; }
# run NAME CMD...: runs a step, appends its output to the log; fails the script on error.
run() {
  local name="$1"; shift
  echo "== $name: $*" >>"$LOG"
  "$@" >>"$LOG" 2>&1 || { echo "bench/ball.sh: step '$name' failed (exit $?), see $LOG" >&2; FAILED=$((FAILED + 1)); return 1; }
}

ROWS=()
# row NAME OUTDIR SECONDS: one table row from OUTDIR/report.json.
row() {
  local v
  v=$("$UTIL" get "$2/report.json" /metrics/num_vertices /metrics/num_tets /optimization/E_I_after_vsem \
      /metrics/E_I /metrics/folded_tets /metrics/D_V/mean /metrics/D_V/p50 /metrics/D_V/p95 \
      /metrics/boundary_sphere_error /metrics/overlap_fraction) || return 1
  ROWS+=("$(printf '%s\t%s\t%s' "$1" "$v" "$3")")
}
# ball_step NAME INPUT OUTDIR [ball options...]
ball_step() {
  local name="$1" in="$2" dir="$3"; shift 3
  local t0 t1
  t0=$(now)
  run "$name" "$BIN" ball "$in" -o "$dir" --max-iterations "$ITERS" "$@" || return 1
  t1=$(now)
  row "$name" "$dir" "$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.1f", b - a }')"
}

for ((s = 1; s <= SEEDS; ++s)); do
  echo "creature seed $s ..." >&2
  m="$WORK/creature$s.vtk"
  [ -f "$m" ] || run "generate $s" "$BIN" generate --shape creature --seed "$s" --tets --tet-count "$TETS" \
    --vertices "$VERTS" -o "$m" || continue
  ball_step "creature $s" "$m" "$WORK/creature$s"
done

SPEED=""
if [ -f "$DATA/spot.obj" ]; then
  echo "spot ..." >&2
  spot="$WORK/spot$SPOT_TETS.vtk"
  [ -f "$spot" ] || run "tetrahedralize spot" "$BIN" tetrahedralize "$DATA/spot.obj" --tets "$SPOT_TETS" -o "$spot"
  if [ -f "$spot" ]; then
    ball_step "spot" "$spot" "$WORK/spot" --split-chords
    echo "speed (spot, 500 iterations) ..." >&2
    t0=$(now)
    if run "speed" "$BIN" ball "$spot" -o "$WORK/speed" --max-iterations 500 --tolerance 0; then
      t1=$(now)
      SPEED=$("$UTIL" get "$WORK/speed/report.json" /metrics/num_vertices /metrics/num_tets /optimization/iterations \
        /optimization/polish_iterations /optimization/seconds/cg /optimization/seconds/cg_per_iteration \
        /optimization/seconds/cg_energy_gradient /optimization/seconds/cg_preconditioner_solves \
        /optimization/seconds/preconditioner_factor /optimization/seconds/sphere_map /optimization/seconds/vsem \
        /optimization/seconds/post_untangle_polish /optimization/seconds/total)
      SPEED="$SPEED	$(awk -v a="$t0" -v b="$t1" 'BEGIN { printf "%.2f", b - a }')"
    fi
  fi
else
  echo "bench/ball.sh: $DATA/spot.obj not found; spot rows skipped (set SHAPEMAP_DATA)" >&2
fi

if [ $REAL = 1 ]; then
  for f in "$DATA"/*.off; do
    [ -f "$f" ] || continue
    b=$(basename "$f" .off)
    echo "$b ..." >&2
    ball_step "$b (30k tets)" "$f" "$WORK/$b" --tets 30000
  done
fi

{
  echo "# bench/ball.sh ($(date -u +%Y-%m-%d), $(nproc) cores, $ITERS CG iterations per quality row)"
  echo
  echo "| mesh | vertices | tets | E_I after VSEM | E_I final | folded tets | mean D_V | p50 | p95 | boundary err | covered twice | wall s |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|---|"
  for r in "${ROWS[@]}"; do
    IFS=$'\t' read -r name nv nt e0 e1 fo dv p50 p95 be ov secs <<<"$r"
    ovp=$(awk -v o="$ov" 'BEGIN { if (o == "-") print "-"; else printf "%.2f%%", 100 * o }')
    echo "| $name | $nv | $nt | $e0 | $e1 | $fo | $dv | $p50 | $p95 | $be | $ovp | $secs |"
  done
  echo
  [ ${#ROWS[@]} -gt 0 ] && printf '%s\n' "${ROWS[@]}" | awk -F'\t' '
    { n++; if ($6 == 0) f++; if ($7 <= 0.03) d++; if ($5 <= 0.5 * $4) e++; if ($10 <= 1e-9) b++ }
    END { printf "Targets met (of %d rows): 0 folded tets %d; mean D_V <= 0.03 %d; E_I final <= half of after VSEM %d; boundary <= 1e-9 %d\n", n, f, d, e, b }'
  if [ -n "$SPEED" ]; then
    IFS=$'\t' read -r nv nt it pit cg per eg ps fac sph vsem post tot wall <<<"$SPEED"
    echo
    echo "Speed (spot, \`ball --max-iterations 500 --tolerance 0\`, $nv vertices / $nt tets): CG $cg s for $((it - pit)) iterations ($per s each: energy + gradient $eg s, preconditioner solves $ps s; factorization $fac s); sphere map $sph s, VSEM $vsem s, post-step $post s; total $tot s, wall $wall s. Target: <= 5 s for 500 iterations."
  fi
} | tee "$OUT"
[ "$FAILED" = 0 ] || { echo "bench/ball.sh: $FAILED step(s) failed, see $LOG" >&2; exit 1; }
