#!/usr/bin/env bash
# Headless simulated tactile exploration: probe_sim + the GPAtlasRRT pipeline + the exploration
# node, on a procedural object by default. Usage: run_demo.sh [OBJECT] [SCALE] [extra roslaunch args]
set -eo pipefail
export PATH=/usr/bin:$PATH
root=$(cd "$(dirname "$0")/.." && pwd)
object=${1:-procedural:mug}
scale=${2:-1.0}
shift $(( $# < 2 ? $# : 2 ))

# roslaunch runs nodes in ROS_HOME, so a mesh path must be absolute.
if [[ "$object" != procedural:* ]]; then
  if [[ ! -f "$object" ]]; then
    echo "demo: mesh file '$object' not found" >&2
    exit 2
  fi
  object=$(realpath "$object")
fi

# The left arm holds the probe (approaches planned for it) unless the arguments say otherwise:
# use_arm:=false gives the free-floating probe.
if [[ " $* " != *" use_arm:="* ]]; then
  set -- use_arm:=true "$@"
fi

results="$root/results/demo_$(date +%Y%m%d_%H%M%S)"
# A private master port, so the demo neither needs nor disturbs a running roscore.
export ROS_MASTER_URI=http://localhost:${DEMO_ROS_PORT:-11511}
# shellcheck disable=SC1091
source "$root/catkin_ws/devel/setup.bash"
echo "[demo] exploring '$object' (scale $scale); results in $results"
roslaunch --screen probe_sim_ros sim_exploration.launch object:="$object" scale:="$scale" results_dir:="$results" "$@" 2>&1 \
  | grep --line-buffered -E "exploration:|segmentation: object|gp_model: fitted|probe_sim: ready|ERROR|FATAL" \
  | sed -u -e 's/\x1b\[[0-9;]*m//g' -e 's/^\[ *\([A-Z]*\)\] \[[0-9.]*\]: /[\1] /' || true

if [[ ! -f "$results/report.json" ]]; then
  echo "[demo] no report was written: the exploration did not run (see the errors above)" >&2
  exit 1
fi
/usr/bin/python3 - "$results" <<'PY'
import json, sys
d = sys.argv[1]
r = json.load(open(f"{d}/report.json"))
m = r.get("final_metrics") or {}
print("[demo] ---------------------------------------------------------------")
left = r.get("final_unreachable_candidates") or 0
share = r.get("final_unreachable_area_fraction") or 0
print(f"[demo] status: {r['status']}  (the loop's stop reason: {r['stop_reason']}"
      + (f"; {left} candidates were left out of the approach's reach" if left else "")
      + (f", {100 * share:.1f}% of the atlas's area" if share else "") + ")")
print(f"[demo] actions: {r['actions']}, contacts: {r['contacts']}, strategy {r['settings']['strategy']}, stop rule: V_max {r['settings']['v_max']}"
      + (f" or position sd {1000 * r['settings']['max_position_sd_m']:g} mm" if r['settings'].get('max_position_sd_m') else " alone"))
if m:
    print(f"[demo] shape RMSE predicted->truth {1000*m['rmse_pred_to_gt_m']:.1f} mm, truth->predicted "
          f"{1000*m['rmse_gt_to_pred_m']:.1f} mm, F-score@5mm {m['fscore_5mm']:.2f}")
    if m.get("coverage_2sd") is not None and m.get("sharpness") is not None:
        print(f"[demo] position sd: median {1000*m['position_sd_m']:.1f} mm, coverage {m['coverage_2sd']:.2f} "
              "(truth within 2 sd), sharpness {:.2f} (median sd / median error)".format(m['sharpness']))
e = r.get("recent_target_error_m")
if e is not None:
    print(f"[demo] the last touches found the surface {1000*e:.1f} mm (median) from where the model predicted it")
print(f"[demo] approach: {r.get('approach_collisions')} collision(s) on the way to the touches, "
      f"{r.get('retreat_collisions')} on the way back, {r.get('unreachable_touches')} touch(es) refused as unreachable")
print(f"[demo] results: {d}/ (report.json, surface.ply, collision_map.bt, exploration.png)")
PY
