#!/usr/bin/env bash
# Runs every test of the workspace (gtest, rostest), the install-space test
# (scripts/test_install_space.sh), then catkin_lint, and prints one closing line
# "N passed, N failed"; exits non-zero on any failure.
set -uo pipefail
export PATH=/usr/bin:$PATH
JOBS=${1:-2}
root=$(cd "$(dirname "$0")/.." && pwd)
ws="$root/catkin_ws"
results="$ws/build/test_results"

rm -rf "$results"
# ROS's setup scripts read unset variables: source them without -u.
set +u
# shellcheck disable=SC1091
source "$ws/devel/setup.bash"
set -u
log_dir=$(mktemp -d)
# Progress as it comes (the gtest lines and errors); the full log stays in $log_dir.
(cd "$ws" && catkin_make run_tests -j"$JOBS" -DPYTHON_EXECUTABLE=/usr/bin/python3) 2>&1 | tee "$log_dir/run_tests.log" \
  | grep --line-buffered -E "^\[ *(RUN|OK|FAILED|PASSED|SKIPPED)|^\[==========\]|Error|error:|FAILURE|ERROR"
build_status=${PIPESTATUS[0]}
echo "[test] full log: $log_dir/run_tests.log"

# catkin_make install, then a short exploration from the install space alone; it writes its
# JUnit result into $results, so the summary counts it.
install_start=$SECONDS
bash "$root/scripts/test_install_space.sh" "$JOBS" 2>&1 | tee "$log_dir/install_space.log"
echo "[test] install-space test: $((SECONDS - install_start)) s"

lint_failed=0
if catkin_lint -W1 --strict "$ws/src" >"$log_dir/catkin_lint.log" 2>&1; then
  echo "[lint] catkin_lint clean"
else
  echo "[lint] catkin_lint reported problems:"
  cat "$log_dir/catkin_lint.log"
  lint_failed=1
fi

summary=$(/usr/bin/python3 "$root/scripts/summarize_test_results.py" "$results" "$build_status" "$lint_failed")
status=$?
if [ $status -ne 0 ]; then
  # CI keeps only the end of this output: the warnings before a failure usually say why.
  echo "[test] the last warnings and errors of the log:"
  grep -E "WARN|ERROR|Error|error:|FAIL" "$log_dir/run_tests.log" | tail -n 60
fi
echo "$summary"
exit $status
