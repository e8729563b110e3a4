#!/usr/bin/env bash
# The install space works on its own: `catkin_make install` (into the workspace's install/, reusing
# the build folder, so only the install step runs), then, in an environment that has only
# install/setup.bash sourced, a short `roslaunch probe_sim_ros sim_exploration.launch` must write
# report.json and exploration.png; the installed gpatlas_bench must find its plot script.
# Writes a JUnit result to catkin_ws/build/test_results/install_space/ (counted by
# run_tests.sh's summary) and exits non-zero on any failure.
#   scripts/test_install_space.sh [JOBS]
set -uo pipefail
export PATH=/usr/bin:$PATH
JOBS=${1:-2}
root=$(cd "$(dirname "$0")/.." && pwd)
ws="$root/catkin_ws"
install="$ws/install"
results_xml_dir="$ws/build/test_results/install_space"
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
mkdir -p "$results_xml_dir"

declare -a case_names case_failures case_times
record() {  # name, failure message ("" = passed), seconds
  case_names+=("$1"); case_failures+=("$2"); case_times+=("$3")
  if [ -z "$2" ]; then echo "[install] $1: ok ($3 s)"; else echo "[install] $1: FAILED: $2"; fi
}
write_junit() {
  local failures=0 i
  for i in "${!case_names[@]}"; do [ -n "${case_failures[$i]}" ] && failures=$((failures + 1)); done
  {
    echo '<?xml version="1.0" encoding="UTF-8"?>'
    echo "<testsuite name=\"install_space\" tests=\"${#case_names[@]}\" failures=\"$failures\" errors=\"0\">"
    for i in "${!case_names[@]}"; do
      echo "  <testcase classname=\"install_space\" name=\"${case_names[$i]}\" time=\"${case_times[$i]}\">"
      if [ -n "${case_failures[$i]}" ]; then
        local message
        message=$(printf '%s' "${case_failures[$i]}" | sed -e 's/&/\&amp;/g' -e 's/</\&lt;/g' -e 's/>/\&gt;/g' -e 's/"/\&quot;/g')
        echo "    <failure message=\"$message\"/>"
      fi
      echo "  </testcase>"
    done
    echo "</testsuite>"
  } >"$results_xml_dir/install_space.xml"
  return "$failures"
}

# 1. catkin_make install (the build folder's own configuration; the install prefix is its default).
start=$SECONDS
if (cd "$ws" && catkin_make install -j"$JOBS" -DPYTHON_EXECUTABLE=/usr/bin/python3) >"$tmp/install.log" 2>&1; then
  record catkin_make_install "" $((SECONDS - start))
else
  record catkin_make_install "catkin_make install failed: $(tail -n 5 "$tmp/install.log" | tr '\n' ' ')" $((SECONDS - start))
  write_junit
  exit 1
fi

# Only the install space: a clean environment, no devel space on any path.
in_install() {
  env -i HOME="$HOME" PATH=/usr/bin:/bin LANG=C.UTF-8 ROS_MASTER_URI="http://localhost:$port" \
    bash -c 'source "$0/setup.bash" && "$@"' "$install" "$@"
}
port=$(/usr/bin/python3 -c 'import socket; s = socket.socket(); s.bind(("", 0)); print(s.getsockname()[1])')

# 2. The packages resolve into the install space, with the config and the plot scripts.
start=$SECONDS
problem=""
for pkg in gpatlas_ros probe_sim_ros probe_sim; do
  where=$(in_install rospack find "$pkg" 2>&1)
  case "$where" in
    "$install"/*) ;;
    *) problem+="rospack find $pkg: '$where' is not in $install; " ;;
  esac
done
for file in share/gpatlas_ros/config/pipeline.yaml share/probe_sim/config/simulation.yaml share/gpatlas_ros/scripts/plot_exploration.py \
            share/gpatlas_ros/nodelet_plugins.xml share/gpatlas_ros/launch/pipeline.launch \
            share/gpatlas_ros/rviz/exploration.rviz share/probe_sim_ros/launch/sim_exploration.launch \
            share/probe_sim_ros/rviz/sim.rviz lib/gpatlas_ros/exploration_node lib/gpatlas_ros/plot_exploration.py \
            lib/probe_sim_ros/probe_sim_node lib/probe_sim/gpatlas_bench lib/probe_sim/plot_bench.py \
            share/gpatlas_geometry/scripts/shape_views.py; do
  [ -e "$install/$file" ] || problem+="$file not installed; "
done
# gpatlas_bench --plot runs the script whose path is compiled in: it must be the installed one.
bench_script=$(strings "$install/lib/probe_sim/gpatlas_bench" 2>/dev/null | grep -o '/[^"]*plot_bench\.py' | head -n 1)
[ "$bench_script" = "$install/lib/probe_sim/plot_bench.py" ] || problem+="the installed gpatlas_bench runs '$bench_script'; "
# ... and reads the installed simulation file by default.
bench_scene=$(strings "$install/lib/probe_sim/gpatlas_bench" 2>/dev/null | grep -o '/[^"]*simulation\.yaml' | head -n 1)
[ "$bench_scene" = "$install/share/probe_sim/config/simulation.yaml" ] || problem+="the installed gpatlas_bench reads '$bench_scene'; "
record installed_files "$problem" $((SECONDS - start))

# 3. A short simulated exploration from the install space.
start=$SECONDS
results="$tmp/results"
in_install timeout 240 roslaunch -p "$port" probe_sim_ros sim_exploration.launch object:=procedural:sphere \
  size:=0.12 max_actions:=2 results_dir:="$results" >"$tmp/roslaunch.log" 2>&1
launch_status=$?
problem=""
if [ ! -s "$results/report.json" ]; then
  problem="no report.json (roslaunch exited with $launch_status): $(grep -E 'ERROR|error|not found|cannot' "$tmp/roslaunch.log" | head -n 5 | tr '\n' ' ')"
elif ! /usr/bin/python3 -c 'import json, sys; r = json.load(open(sys.argv[1])); sys.exit(0 if r["actions"] == len(r["history"]) and 1 <= r["actions"] <= 2 else 1)' "$results/report.json"; then
  problem="report.json: unexpected content: $(head -c 300 "$results/report.json")"
elif [ ! -s "$results/exploration.png" ]; then
  problem="no exploration.png (plot_exploration.py not found from the install space?)"
fi
record sim_exploration_from_install "$problem" $((SECONDS - start))
if [ -n "$problem" ]; then
  echo "[install] the end of the roslaunch log:"
  tail -n 30 "$tmp/roslaunch.log"
fi

write_junit
status=$?
[ $status -eq 0 ] && echo "[install] install space ok" || echo "[install] $status install-space check(s) failed"
exit $status
