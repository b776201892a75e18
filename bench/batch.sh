#!/usr/bin/env bash
# bench/batch.sh: `shapemap batch` on all pairs of 6 generated shapes with BIM, on 1 and on 2
# local Dask workers, against the same pairs run directly (`shapemap surface-map`, one after
# the other, one thread each). Prints the times, the per-shape preparations counted in the
# summary, and pass/fail against the issue-21 targets:
#   - each shape prepared once per batch, BIM's per-surface stage too (shared by the workers);
#   - 2 workers >= 1.7x faster than 1 worker;
#   - the Python and Dask layers add <= 5%: the 1-worker batch against the direct runs
#     (which also render pictures), and against the time inside its own tasks (shapes and pairs).
# Then what the machine gives two jobs at once (one pair alone, then two copies together), and
# each batch's timeline, from the per-task worker, start, end and CPU seconds in summary.json:
# utilization (busy worker-seconds / (wall x workers)), the serial head (start -> first task),
# the tail (the last-but-one worker out of tasks -> end), and the task time and task CPU on 1
# and on 2 workers (more CPU on 2: tasks slow each other down, e.g. memory bandwidth; more time
# than CPU: they waited for a core or a lock).
# The 1- and 2-worker batches run in turn, --repeats times (A B A B ..., fresh output folders):
# the speed-up is the median of the paired ratios and the times are medians, so a comparison
# holds when the shared machine's speed drifts between runs.
# Usage: bench/batch.sh [--vertices N] [--repeats R] [--build DIR] [--work DIR] [--no-direct]
#        (default 4000 vertices, 3 repeats, build, bench/out/batch; --no-direct skips the direct
#        runs). 4000 vertices: the Python and Dask layers cost a fixed ~0.3 s per batch (the
#        interpreter, numpy, dask), 5% of a batch of 1500-vertex shapes (5.5 s of tasks) but
#        1% at 4000 (37 s), still far below the scans users map (SHREC'07 5k-15k vertices).
set -euo pipefail
here=$(cd "$(dirname "$0")/.." && pwd)
build=$here/build
work=$here/bench/out/batch
vertices=4000
repeats=3
direct=1
while [ $# -gt 0 ]; do
  case $1 in
    --vertices) vertices=$2; shift 2 ;;
    --build) build=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    --repeats) repeats=$2; shift 2 ;;
    --no-direct) direct=0; shift ;;
    *) echo "bench/batch.sh: unknown option $1" >&2; exit 2 ;;
  esac
done
exe=$build/shapemap
[ -x "$exe" ] || { echo "bench/batch.sh: $exe missing (make build)" >&2; exit 2; }
export OMP_WAIT_POLICY=passive
rm -rf "$work"
mkdir -p "$work/shapes"
shapes=()
k=0
for s in creature sphere ellipsoid cube-sphere creature ellipsoid; do
  k=$((k + 1))
  "$exe" --quiet generate --shape "$s" --vertices "$vertices" --seed "$k" -o "$work/shapes/s$k.obj"
  shapes+=("$work/shapes/s$k.obj")
done
now() { date +%s.%N; }
calc() { /usr/bin/python3 -c "print($1)"; }

# The same pairs directly, one process per pair, one thread.
t_direct=0
if [ $direct = 1 ]; then
  t0=$(now)
  for ((i = 0; i < ${#shapes[@]}; i++)); do
    for ((j = i + 1; j < ${#shapes[@]}; j++)); do
      "$exe" --quiet --threads 1 surface-map "${shapes[$i]}" "${shapes[$j]}" -o "$work/direct/$i-$j" >/dev/null
    done
  done
  t_direct=$(calc "$(now) - $t0")
fi

# What this machine gives two jobs at once: one pair (s1, s5: the longest of the batch) alone,
# then two copies of it at the same time, each on 1 thread. Each copy slower than alone (other
# programs, memory, shared physical cores) bounds what 2 workers can gain.
one_pair() { "$exe" --quiet --threads 1 surface-map "${shapes[0]}" "${shapes[4]}" -o "$work/ceiling/$1" >/dev/null; }
t0=$(now); one_pair alone; t_alone=$(calc "$(now) - $t0")
t0=$(now); one_pair a & one_pair b & wait; t_two=$(calc "$(now) - $t0")

run_batch() {  # workers; the run's wall-clock start and end go to $work/wall$1
  local t e
  rm -rf "$work/batch$1"
  t=$(now)
  "$exe" --quiet --threads 1 batch "${shapes[@]}" -o "$work/batch$1" --method bim --workers "$1"
  e=$(now)
  echo "$t $e" > "$work/wall$1"
  calc "$e - $t"
}
total() { /usr/bin/python3 -c "import json,sys; print(json.load(open(sys.argv[1]))[sys.argv[2]])" "$work/batch$1/summary.json" "$2"; }
t1s=(); t2s=(); ratios=(); layers=()
for ((r = 0; r < repeats; r++)); do
  a=$(run_batch 1)
  k=$(total 1 task_seconds)  # the time inside the batch's own tasks (shapes and pairs)
  layers+=("$(calc "($a - $k) / $k * 100")")
  b=$(run_batch 2)
  t1s+=("$a"); t2s+=("$b"); ratios+=("$(calc "$a / $b")")
done
median() { /usr/bin/python3 -c "import statistics, sys; print(statistics.median(map(float, sys.argv[1:])))" "$@"; }
t1=$(median "${t1s[@]}"); t2=$(median "${t2s[@]}")
timeline() {  # workers: the timeline figures of that batch, from its summary.json
  PYTHONPATH=$build/python /usr/bin/python3 - "$work/batch$1/summary.json" "$work/wall$1" <<'PY'
import json, sys
from shapemap.batch import task_timeline
s = json.load(open(sys.argv[1]))
start, end = map(float, open(sys.argv[2]).read().split())
t = task_timeline(s, start, end)
k = t["task_seconds"]
print(f"{t['utilization'] * 100:.0f} {t['head']:.2f} {t['tail']:.2f} {t['busy']:.1f} "
      f"{k.get('shape', 0):.1f} {k.get('pair', 0):.1f} {t['cpu']:.1f}")
PY
}
read -r util1 head1 tail1 busy1 shape1 pair1 cpu1 < <(timeline 1)
read -r util2 head2 tail2 busy2 shape2 pair2 cpu2 < <(timeline 2)
per_shape() {  # BIM preparations of each shape, e.g. 1,1,1,1,1,1
  /usr/bin/python3 -c "import json,sys; s=json.load(open(sys.argv[1]))['shapes']; print(','.join(str(s[n].get('bim_preparations', 0)) for n in sorted(s)))" "$work/batch$1/summary.json"
}
prep1=$(total 1 preparations); prep2=$(total 2 preparations)
bim1=$(total 1 bim_preparations); bim2=$(total 2 bim_preparations)
each1=$(per_shape 1); each2=$(per_shape 2)

# The time inside the batch's own tasks (shape preparations, shape tasks with BIM's stage,
# pairs: the maps computed through the module, files written).
tasks1=$(total 1 task_seconds)
speedup=$(median "${ratios[@]}")
dask_overhead=$(median "${layers[@]}")
overhead=$(calc "($t1 - $t_direct) / $t_direct * 100 if $t_direct else 0")
pf() { /usr/bin/python3 -c "print('PASS' if ($1) else 'FAIL')"; }
printf 'bench/batch.sh: 6 shapes of %d vertices, 15 pairs, BIM, %s\n' "$vertices" "$(date -u +%FT%TZ)"
if [ $direct = 1 ]; then printf '  direct (15 x shapemap surface-map, 1 thread): %.1f s\n' "$t_direct"; fi
printf '  batches (1 worker, 2 workers in turn, %d times): 1 worker %s s; 2 workers %s s\n' "$repeats" \
  "$(printf '%.1f ' "${t1s[@]}")" "$(printf '%.1f ' "${t2s[@]}")"
printf '  batch, 1 worker:  %.1f s   preparations %s, BIM preparations %s (per shape %s)\n' "$t1" "$prep1" "$bim1" "$each1"
printf '  batch, 2 workers: %.1f s   preparations %s, BIM preparations %s (per shape %s)\n' "$t2" "$prep2" "$bim2" "$each2"
printf '  each shape prepared once, BIM stage once: %s\n' \
  "$(pf "$prep1 == 6 and $prep2 == 6 and '$each1' == '$each2' == '1,1,1,1,1,1'")"
printf '  2 workers vs 1 (median of the paired ratios): %.2fx (>= 1.7x):    %s\n' "$speedup" "$(pf "$speedup >= 1.7")"
printf '  time inside the tasks (1 worker): %.1f s\n' "$tasks1"
if [ $direct = 1 ]; then
  printf '  Python/Dask layers vs direct CLI runs: %+.1f%% (<= 5%%): %s\n' "$overhead" "$(pf "$overhead <= 5")"
fi
printf '  Dask layer vs the tasks themselves (median):    %+.1f%% (<= 5%%): %s\n' "$dask_overhead" "$(pf "$dask_overhead <= 5")"
if [ $direct = 1 ]; then echo "  (the CLI runs also render report.html and PNG pictures, which batch does not)"; fi
printf '  machine: one pair alone %.2f s, two copies at once %.2f s: %.2fx the throughput (2.00: two free cores)\n' \
  "$t_alone" "$t_two" "$(calc "2 * $t_alone / $t_two")"
echo "  timeline (per-task worker, start, end in summary.json; wall = this script's clock around the batch):"
printf '    1 worker:  utilization %s%%, head %.2f s, tail %.2f s; tasks %.1f s (shapes %.1f, pairs %.1f), CPU %.1f s\n' \
  "$util1" "$head1" "$tail1" "$busy1" "$shape1" "$pair1" "$cpu1"
printf '    2 workers: utilization %s%%, head %.2f s, tail %.2f s; tasks %.1f s (shapes %.1f, pairs %.1f), CPU %.1f s\n' \
  "$util2" "$head2" "$tail2" "$busy2" "$shape2" "$pair2" "$cpu2"
printf '    task time on 2 workers vs 1: %.2fx, task CPU: %.2fx (1.00: tasks do not slow each other down;\n' \
  "$(calc "$busy2 / $busy1")" "$(calc "$cpu2 / $cpu1")"
echo "      time above CPU: the tasks waited for a core (other programs) or a lock)"
