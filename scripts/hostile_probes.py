#!/usr/bin/env python3
"""The hostile set of issue 51, re-runnable: bad files, services before a model and with
NaN / inf / negative / huge fields, hostile clouds and contacts, gpatlas_bench's numeric flags,
a probe driver killed mid-exploration, and a wait nobody answers. Each probe is classified:

  correct   the answer the input deserves (a refusal that is not an error counts here too)
  refused   an error that names the input and what is wrong with it
  unclear   refused or ignored without saying what (the probe's expected words missing)
  wrong     success on input that deserves an error, or the wrong result
  crash     the process died by a signal, or the nodelet manager is gone
  hang      no answer within the probe's time

Not part of `make test` (about 10-15 minutes). After `make build`, from the repository:

    source catkin_ws/devel/setup.bash && /usr/bin/python3 scripts/hostile_probes.py [--only a,d] [--table FILE]

ROS probes run one at a time on a master of their own (a free port). Needs ../shared (the
recorded cloud, the scanned meshes): without it, it says so and exits 0.
"""
import argparse
import math
import os
import random
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(REPO), "shared")
PCD = os.path.join(SHARED, "data", "table_scene_mug_stereo_textured.pcd")
MM_MESH = os.path.join(SHARED, "objects", "funnel_big_mm.stl")
# The rostests' camera pose of the recorded cloud (gpatlas_ros/test/mug_cloud_camera.launch).
CAMERA_POSE = "0 0 0.528868 -0.627695 0.615650 -0.340126 0.333600"
CAMERA_FRAME = "camera_depth_optical_frame"
ANSI = re.compile(r"\x1b\[[0-9;]*m")
OUTCOMES = ["correct", "refused", "unclear", "wrong", "crash", "hang"]
CATEGORIES = {
    "a": "files (cloud_file_publisher, recorded_cloud.launch, gpatlas_bench)",
    "b": "services before and after a model, hostile fields",
    "c": "topics: hostile clouds and contacts, late subscribers after reset",
    "d": "gpatlas_bench flags, merges",
    "e": "a node killed mid-exploration",
    "f": "waits nobody answers",
}
BENCH_FAST = ["--object", "procedural:sphere", "--size-m", "0.1", "--strategy", "random", "--seeds", "0",
              "--max-actions", "0", "--no-plot", "--no-reachability", "--set", "view/max_surface_points=200"]


class Results:
    def __init__(self):
        self.rows = []

    def add(self, category, name, outcome, detail=""):
        assert outcome in OUTCOMES, outcome
        detail = " ".join(detail.split())[:220]
        self.rows.append((category, name, outcome, detail))
        print("[%s] %-8s %s: %s" % (category, outcome, name, detail), flush=True)

    def table(self):
        lines = ["| category | probes | " + " | ".join(OUTCOMES) + " |", "|---" * (len(OUTCOMES) + 2) + "|"]
        for cat, title in CATEGORIES.items():
            rows = [r for r in self.rows if r[0] == cat]
            if rows:
                counts = [sum(1 for r in rows if r[2] == o) for o in OUTCOMES]
                lines.append("| (%s) %s | %d | %s |" % (cat, title, len(rows), " | ".join(map(str, counts))))
        counts = [sum(1 for r in self.rows if r[2] == o) for o in OUTCOMES]
        lines.append("| **all** | %d | %s |" % (len(self.rows), " | ".join(map(str, counts))))
        bad = [r for r in self.rows if r[2] not in ("correct", "refused")]
        return "\n".join(lines + [""] + ["- (%s) %s: %s: %s" % r for r in bad])


def run(cmd, timeout, **kwargs):
    """rc, the output (stdout and stderr), hung. A hung process group is killed."""
    proc = subprocess.Popen(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
                            start_new_session=True, **kwargs)
    try:
        out, _ = proc.communicate(timeout=timeout)
        return proc.returncode, ANSI.sub("", out), False
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)
        out, _ = proc.communicate()
        return None, ANSI.sub("", out), True


def exit_outcome(rc, out, hung, words, success_ok=False):
    """A process given bad input: it should end with an error naming `words` (all of them)."""
    if hung:
        return "hang", "no exit; last: " + out[-160:]
    if rc < 0 or rc >= 128:
        return "crash", "rc %d: %s" % (rc, out[-160:])
    if rc == 0:
        return ("correct" if success_ok else "wrong"), "exit 0: " + out[-160:]
    missing = [w for w in words if w.lower() not in out.lower()]
    line = next((l for l in reversed(out.splitlines()) if any(w.lower() in l.lower() for w in words)), out[-160:])
    return ("unclear" if missing else "refused"), ("missing %s: " % missing if missing else "") + line.strip()


# ----------------------------------------------------------------------------------------------
# (a) files
def pcd_header(points, data="binary"):
    return ("# .PCD v0.7\nVERSION 0.7\nFIELDS x y z\nSIZE 4 4 4\nTYPE F F F\nCOUNT 1 1 1\nWIDTH %d\nHEIGHT 1\n"
            "VIEWPOINT 0 0 0 1 0 0 0\nPOINTS %d\nDATA %s\n" % (points, points, data)).encode()


def write_bad_files(tmp):
    rnd = random.Random(51)
    files = {
        "empty.pcd": b"",
        "random.pcd": bytes(rnd.getrandbits(8) for _ in range(4096)),
        "header_only.pcd": pcd_header(1000),
        "truncated.pcd": pcd_header(1000) + b"\0" * (12 * 500),
        "ascii_bad.pcd": pcd_header(3, "ascii") + b"1 2 3\n4 five 6\n",
        "zero_points.pcd": pcd_header(0),
        "random.ply": bytes(rnd.getrandbits(8) for _ in range(4096)),
        "header_only.ply": b"ply\nformat ascii 1.0\nelement vertex 100\nproperty float x\nproperty float y\n"
                           b"property float z\nend_header\n",
        "empty.stl": b"",
        "random.stl": bytes(rnd.getrandbits(8) for _ in range(4096)),
        "cloud.txt": b"1 2 3\n",
        "corrupt.yaml": b"exploration:\n  v_max: [0.1\n  max_actions: : :\n",
        "wrong_type.yaml": b"exploration:\n  max_actions: many\n",
    }
    paths = {}
    for name, data in files.items():
        paths[name] = os.path.join(tmp, name)
        with open(paths[name], "wb") as f:
            f.write(data)
    paths["missing.pcd"] = os.path.join(tmp, "no_such_file.pcd")
    paths["missing.stl"] = os.path.join(tmp, "no_such_file.stl")
    return paths


def probes_files(res, tmp, paths, ros):
    for name in ["empty.pcd", "random.pcd", "header_only.pcd", "truncated.pcd", "ascii_bad.pcd", "zero_points.pcd",
                 "random.ply", "header_only.ply", "cloud.txt", "missing.pcd"]:
        rc, out, hung = run(["rosrun", "gpatlas_ros", "cloud_file_publisher", "_file:=" + paths[name],
                             "_wait_for_subscriber_s:=1"], 30, env=ros.env)
        res.add("a", "cloud_file_publisher " + name, *exit_outcome(rc, out, hung, [paths[name]]))
    # recorded_cloud.launch with a bad file: the camera node's error in the launch's output.
    launch = ros.launch(["gpatlas_ros", "recorded_cloud.launch", "file:=" + paths["random.pcd"], "pipeline:=false"])
    said = launch.wait_for(re.escape(paths["random.pcd"]) + r".*(not|no |cannot|bad|invalid|promises|header)", 40)
    alive = launch.proc.poll() is None
    launch.stop()
    res.add("a", "recorded_cloud.launch random.pcd", "refused" if said and alive else "unclear",
            (said or launch.tail()) + ("" if alive else " (roslaunch ended)"))
    bench_files = [
        ("--object empty.stl", ["--object", paths["empty.stl"]], [paths["empty.stl"]]),
        ("--object random.stl", ["--object", paths["random.stl"]], [paths["random.stl"]]),
        ("--object random.ply", ["--object", paths["random.ply"]], [paths["random.ply"]]),
        ("--object missing.stl", ["--object", paths["missing.stl"]], [paths["missing.stl"], "no such file"]),
        ("--object cloud.txt", ["--object", paths["cloud.txt"]], [paths["cloud.txt"], "extension"]),
        ("--object procedural:nothing", ["--object", "procedural:nothing"], ["nothing"]),
        ("mm mesh without --scale", ["--object", MM_MESH], ["object_scale", "0.001"]),
        # --scale applies to the meshes after it: after the last one it scales nothing.
        ("mm mesh, --scale 0.001 after it", ["--object", MM_MESH, "--scale", "0.001"], ["--scale", "after", "before"]),
        ("--config corrupt.yaml", ["--config", paths["corrupt.yaml"]], ["corrupt.yaml"]),
        ("--config wrong_type.yaml", ["--config", paths["wrong_type.yaml"]], ["max_actions"]),
        ("--simulation corrupt.yaml", ["--simulation", paths["corrupt.yaml"]], ["--simulation"]),
        ("--overlay corrupt.yaml", ["--overlay", paths["corrupt.yaml"]], ["corrupt.yaml"]),
        ("--overlay missing", ["--overlay", paths["missing.pcd"]], [paths["missing.pcd"]]),
    ]
    for name, args, words in bench_files:
        # The object flags come after BENCH_FAST's --object: a second object, which the run must refuse.
        rc, out, hung = run(["rosrun", "probe_sim", "gpatlas_bench"] + BENCH_FAST + args +
                            ["--out", os.path.join(tmp, "bench_a")], 120)
        res.add("a", "gpatlas_bench " + name, *exit_outcome(rc, out, hung, words))
    rc, out, hung = run(["rosrun", "probe_sim", "gpatlas_bench", "--scale", "0.001", "--object", MM_MESH,
                         "--strategy", "random", "--seeds", "0", "--max-actions", "0", "--no-plot", "--no-reachability",
                         "--out", os.path.join(tmp, "bench_mm")], 300)
    ok = rc == 0 and os.path.exists(os.path.join(tmp, "bench_mm", "runs.csv"))
    res.add("a", "gpatlas_bench mm mesh --scale 0.001", "correct" if ok else exit_outcome(rc, out, hung, ["x"])[0],
            out[-160:])


# ----------------------------------------------------------------------------------------------
# (d) gpatlas_bench flags
NUMERIC_FLAGS = {  # flag: values it must accept among -1, 0, 1e10, x (README, --help)
    "--scale": [], "--size-m": [], "--seeds": ["0"], "--max-actions": ["0"], "--jobs": [],
    "--curve-every": ["0"], "--curve-resolution-m": [], "--curve-samples": [], "--variance-every": [],
    "--reach-directions": [], "--shard": [],
}


def read_runs(folder):
    import csv
    with open(os.path.join(folder, "runs.csv")) as f:
        return list(csv.DictReader(f))


def probes_bench_flags(res, tmp):
    for flag, accepted in NUMERIC_FLAGS.items():
        for value in ["-1", "0", "1e10", "x"]:
            out_dir = os.path.join(tmp, "bench_d")
            shutil.rmtree(out_dir, ignore_errors=True)
            rc, out, hung = run(["rosrun", "probe_sim", "gpatlas_bench"] + BENCH_FAST + [flag, value, "--out", out_dir], 180)
            name = "gpatlas_bench %s %s" % (flag, value)
            if value not in accepted:
                res.add("d", name, *exit_outcome(rc, out, hung, [flag, value]))
                continue
            if hung or rc != 0:
                res.add("d", name, "hang" if hung else ("crash" if rc < 0 or rc >= 128 else "wrong"), out[-160:])
                continue
            rows = read_runs(out_dir)
            truth = {"--seeds": ("seed", value), "--max-actions": ("actions", value)}.get(flag)
            good = len(rows) == 1 and (truth is None or rows[0].get(truth[0]) == truth[1])
            res.add("d", name, "correct" if good else "wrong", "runs.csv: %s" % (rows[0] if rows else "empty"))
    for name, args, words in [("unknown flag --sneeds", ["--sneeds", "0"], ["--sneeds"]),
                              ("missing value --max-actions", ["--max-actions"], ["--max-actions", "needs a value"]),
                              ("missing value --set", ["--set"], ["--set", "needs a value"]),
                              ("--set with a flag for its value", ["--set", "--no-plot"], ["--set", "--no-plot"]),
                              ("--set unknown key", ["--set", "exploration/v_maxx=1"], ["v_maxx"]),
                              ("--set v_max=nan", ["--set", "exploration/v_max=nan"], ["v_max"]),
                              ("--set max_position_sd_m=0", ["--set", "exploration/max_position_sd_m=0"],
                               ["max_position_sd_m", "write off"]),
                              ("--strategy unknown", ["--strategy", "nope"], ["nope"]),
                              ("--probe unknown", ["--probe", "finger"], ["finger"]),
                              ("--shard 3/2", ["--shard", "3/2"], ["--shard", "3/2"])]:
        # args last: a flag at the end misses its value
        rc, out, hung = run(["rosrun", "probe_sim", "gpatlas_bench"] + BENCH_FAST +
                            ["--out", os.path.join(tmp, "bench_d")] + args, 120)
        res.add("d", "gpatlas_bench " + name, *exit_outcome(rc, out, hung, words))
    probes_merge(res, tmp)


def probes_merge(res, tmp):
    scene = os.path.join(tmp, "simulation.yaml")
    shutil.copyfile(os.path.join(REPO, "catkin_ws", "src", "probe_sim", "config", "simulation.yaml"), scene)
    args = ["rosrun", "probe_sim", "gpatlas_bench", "--object", "procedural:sphere", "--object", "procedural:box",
            "--size-m", "0.1", "--strategy", "random", "--seeds", "0", "--max-actions", "1", "--no-plot",
            "--no-reachability", "--set", "view/max_surface_points=200", "--simulation", scene]
    shards = [os.path.join(tmp, "shard_%d" % k) for k in (1, 2)]
    for k, folder in zip((1, 2), shards):
        rc, out, hung = run(args + ["--shard", "%d/2" % k, "--out", folder], 300)
        if rc != 0:
            res.add("d", "merge set-up shard %d" % k, "hang" if hung else "wrong", out[-200:])
            return
    merged = os.path.join(tmp, "merged_missing")
    rc, out, hung = run(["rosrun", "probe_sim", "gpatlas_bench", "--merge", shards[0], "--out", merged, "--no-plot"], 120)
    summary = open(os.path.join(merged, "summary.md")).read() if os.path.exists(os.path.join(merged, "summary.md")) else ""
    said = "1 of 2 jobs are missing" in out and "1 of 2 jobs are missing" in summary
    res.add("d", "merge with a shard missing", "refused" if said and rc not in (0, None) else
            exit_outcome(rc, out, hung, ["missing"])[0] if not said else "wrong", out[-200:])
    with open(scene) as f:
        text = f.read()
    with open(scene, "w") as f:
        f.write(re.sub(r"object_position_xy_m: \[[^\]]*\]", "object_position_xy_m: [0.72, 0.0]", text))
    rc, out, hung = run(args + ["--shard", "2/2", "--out", shards[1]], 300)
    merged = os.path.join(tmp, "merged_changed")
    rc, out, hung = run(["rosrun", "probe_sim", "gpatlas_bench", "--merge", shards[0], shards[1], "--out", merged,
                         "--no-plot"], 120)
    outcome, detail = exit_outcome(rc, out, hung, ["different settings"])
    if os.path.exists(os.path.join(merged, "runs.csv")) and outcome == "refused":
        outcome, detail = "wrong", "refused but wrote runs.csv: " + detail
    res.add("d", "merge with --simulation changed between shards", outcome, detail)


# ----------------------------------------------------------------------------------------------
# ROS: a master of our own, launches with their output in a file
class Launch:
    def __init__(self, ros, args, log):
        self.log = log
        self.f = open(log, "w")
        self.proc = subprocess.Popen(["roslaunch", "--wait"] + args, stdout=self.f, stderr=subprocess.STDOUT,
                                     env=ros.env, start_new_session=True)
        self.mark = 0

    def text(self):
        with open(self.log, errors="replace") as f:
            return ANSI.sub("", f.read())

    def tail(self, n=200):
        return self.text()[-n:]

    def since_mark(self):
        return self.text()[self.mark:]

    def set_mark(self):
        self.mark = len(self.text())

    def wait_for(self, pattern, timeout, since_mark=False):
        end = time.time() + timeout
        while time.time() < end:
            text = self.since_mark() if since_mark else self.text()
            m = re.search(pattern, text, re.I)
            if m:
                start = text.rfind("\n", 0, m.start()) + 1
                stop = text.find("\n", m.end())
                return text[start:stop if stop >= 0 else None].strip()
            time.sleep(0.5)
        return None

    def stop(self):
        if self.proc.poll() is None:
            os.killpg(self.proc.pid, signal.SIGINT)
            try:
                self.proc.wait(30)
            except subprocess.TimeoutExpired:
                os.killpg(self.proc.pid, signal.SIGKILL)
                self.proc.wait()
        self.f.close()


class Ros:
    def __init__(self, tmp):
        with socket.socket() as s:
            s.bind(("localhost", 0))
            port = s.getsockname()[1]
        # Line-buffered node output: the probes read the launches' logs as they are written.
        self.env = dict(os.environ, ROS_MASTER_URI="http://localhost:%d" % port, ROS_LOG_DIR=os.path.join(tmp, "roslog"),
                        ROSCONSOLE_STDOUT_LINE_BUFFERED="1", PYTHONUNBUFFERED="1")
        os.environ.update(ROS_MASTER_URI=self.env["ROS_MASTER_URI"], ROS_LOG_DIR=self.env["ROS_LOG_DIR"])
        self.tmp = tmp
        self.core = subprocess.Popen(["roscore", "-p", str(port)], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                                     env=self.env, start_new_session=True)
        import rosgraph
        end = time.time() + 60
        while not rosgraph.is_master_online():
            if time.time() > end:
                raise RuntimeError("roscore did not start")
            time.sleep(0.5)
        import rospy
        rospy.init_node("hostile_probes", anonymous=True, disable_signals=True)

    def launch(self, args):
        return Launch(self, args, os.path.join(self.tmp, "launch_%d.log" % time.time_ns()))

    def stop(self):
        os.killpg(self.core.pid, signal.SIGINT)
        try:
            self.core.wait(30)
        except subprocess.TimeoutExpired:
            os.killpg(self.core.pid, signal.SIGKILL)


def node_alive(name):
    import rosnode
    try:
        return rosnode.rosnode_ping(name, max_count=1)
    except Exception:  # noqa: BLE001  the node is gone, or the master
        return False


def call(name, srv_type, timeout=120.0, **fields):
    """(response, None) or (None, 'hang'/'crash'/error text)."""
    import rospy
    try:
        rospy.wait_for_service(name, timeout=20.0)
    except rospy.ROSException:
        return None, "hang: %s not offered" % name
    result = {}

    def worker():
        try:
            result["r"] = rospy.ServiceProxy(name, srv_type)(srv_type._request_class(**fields))
        except Exception as e:  # noqa: BLE001  the service died, or refused the request's encoding
            result["e"] = "%s: %s" % (type(e).__name__, e)
    import threading
    t = threading.Thread(target=worker, daemon=True)
    t.start()
    t.join(timeout)
    if t.is_alive():
        return None, "hang: %s gave no answer in %.0f s" % (name, timeout)
    return result.get("r"), result.get("e")


def answer_outcome(resp, err, ok, words, text):
    """A service answer: ok(resp) -> correct; else the message must match each of `words` (regexes)."""
    if resp is None:
        if err.startswith("hang"):
            return "hang", err
        return ("crash" if not node_alive("/gpatlas/gpatlas_manager") else "unclear"), err
    if ok(resp):
        return "correct", text(resp)
    msg = text(resp)
    missing = [w for w in words if not re.search(w, msg, re.I)]
    if getattr(resp, "success", False) or getattr(resp, "status", 3) in (0, 1):
        return "wrong", "success: " + msg
    return ("unclear" if missing else "refused"), ("missing %s: " % missing if missing else "") + msg


# ----------------------------------------------------------------------------------------------
# (b) services and (c) topics, on the pipeline with the recorded cloud as the camera
def point(x, y, z):
    from geometry_msgs.msg import Point
    return Point(x, y, z)


def touch_at(*points):
    from gpatlas_msgs.msg import Touch
    from geometry_msgs.msg import Vector3
    return Touch(points=list(points), normals=[Vector3(-1, 0, 0)] * len(points))


def observations(contacts, normals=None):
    from gpatlas_msgs.msg import Observations
    from geometry_msgs.msg import Vector3
    obs = Observations(contacts=contacts, contact_normals=normals if normals is not None else [Vector3(-1, 0, 0)] * len(contacts))
    obs.header.frame_id = "world"
    return obs


NAN, INF = float("nan"), float("inf")
TOUCH, CONVERGED, NO_MODEL, STALE, CAP = 0, 1, 2, 4, 5


def next_touch_probes():
    """(name, fields, ok(resp), words of a clear refusal)."""
    import rospy
    some = lambda r: r.status in (TOUCH, CONVERGED, CAP)  # noqa: E731
    never = lambda r: False  # noqa: E731
    return [
        ("next_touch v_max -1", {"use_v_max": True, "v_max": -1.0}, never, ["v_max"]),
        ("next_touch v_max NaN", {"use_v_max": True, "v_max": NAN}, never, ["v_max"]),
        ("next_touch v_max inf", {"use_v_max": True, "v_max": INF}, some, ["v_max"]),
        ("next_touch v_max 1e10", {"use_v_max": True, "v_max": 1e10}, some, ["v_max"]),
        ("next_touch v_max -1 unused", {"v_max": -1.0}, some, ["v_max"]),
        ("next_touch max_position_sd_m NaN", {"stop_rule": 1, "max_position_sd_m": NAN}, never, ["max_position_sd_m"]),
        ("next_touch max_position_sd_m 0", {"stop_rule": 1, "max_position_sd_m": 0.0}, never, ["max_position_sd_m"]),
        ("next_touch max_position_sd_m inf", {"stop_rule": 1, "max_position_sd_m": INF}, never, ["max_position_sd_m"]),
        ("next_touch stop_rule V_max alone", {"stop_rule": 2}, some, ["stop_rule"]),
        ("next_touch stop_rule 9", {"stop_rule": 9}, never, ["stop_rule"]),
        ("next_touch seed 0", {"use_seed": True, "seed": 0}, some, ["seed"]),
        ("next_touch strategy unknown", {"strategy": "no_such_strategy"}, never, ["no_such_strategy"]),
        ("next_touch start NaN", {"use_start": True, "start": point(NAN, 0, 0)}, never, ["start"]),
        ("next_touch start 100 m away", {"use_start": True, "start": point(100, 0, 0)}, some, ["start"]),
        ("next_touch footprint_radius_m -1", {"footprint_radius_m": -1.0}, never, ["footprint_radius_m"]),
        ("next_touch footprint_radius_m NaN", {"footprint_radius_m": NAN}, never, ["footprint_radius_m"]),
        ("next_touch 2 targets, 1 error", {"attempted_targets": [point(0.6, 0, 0.05)] * 2,
                                           "attempted_target_errors_m": [0.01]}, never, ["attempted_target_errors_m"]),
        ("next_touch attempted target NaN", {"attempted_targets": [point(NAN, NAN, NAN)]}, some, ["attempted_targets"]),
        ("next_touch empty_unknown_pokes -5", {"empty_unknown_pokes": -5}, some, ["empty_unknown_pokes"]),
        ("next_touch model_stamp in the future", {"model_stamp": rospy.Time.now() + rospy.Duration(1e6)},
         lambda r: r.status == STALE, ["model_stamp|newer|older|stale"]),
    ]


def service_probes(res, stage):
    """Every service with hostile fields; stage 'before' (no model) or 'after'."""
    from gpatlas_msgs.srv import GetNextTouch, PlanApproach, SelectObject, RemoveObservations, AddObservations, SaveMap
    from geometry_msgs.msg import PointStamped, Vector3
    from std_srvs.srv import Trigger
    P, G, S, M = "/gpatlas/atlas_planner/", "/gpatlas/gp_model/", "/gpatlas/segmentation/", "/gpatlas/collision_map/"
    msg = lambda r: r.message  # noqa: E731
    refused = lambda r: not r.success and bool(r.message)  # noqa: E731
    probes = []
    if stage == "before":
        probes += [
            ("next_touch {} before a model", P + "next_touch", GetNextTouch, {}, lambda r: r.status == NO_MODEL, []),
            ("plan_approach before a map", M + "plan_approach", PlanApproach, {"touch": touch_at(point(0.7, 0, 0.05))},
             refused, []),
            ("select_object before a cloud", S + "select_object", SelectObject,
             {"point": PointStamped(point=point(0.7, 0, 0.05))}, refused, []),
            ("remove_observations last 1 before a model", G + "remove_observations", RemoveObservations, {"last": 1},
             refused, []),
            ("save_map before a map", M + "save_map", SaveMap, {"path": "/tmp/hostile_no_map.bt"}, lambda r: True, []),
        ]
    else:
        probes += [("next_touch {} with a model", P + "next_touch", GetNextTouch, {},
                    lambda r: r.status in (TOUCH, CONVERGED), [])]
        probes += [(n, P + "next_touch", GetNextTouch, f, ok, w) for n, f, ok, w in next_touch_probes()]
    stamped = lambda x, y, z, frame="world": {"point": PointStamped(header=_header(frame), point=point(x, y, z))}  # noqa: E731
    probes += [
        ("plan_approach touch without points", M + "plan_approach", PlanApproach, {"touch": touch_at()}, never_ok, ["point|empty"]),
        ("plan_approach touch NaN", M + "plan_approach", PlanApproach, {"touch": touch_at(point(NAN, 0, 0.05))}, never_ok,
         ["finite|nan"]),
        ("plan_approach touch 100 m away", M + "plan_approach", PlanApproach, {"touch": touch_at(point(100, 0, 0.05)), "start": point(0.3, 0, 0.4)}, refused, []),
        ("plan_approach start inf", M + "plan_approach", PlanApproach,
         {"touch": touch_at(point(0.7, 0, 0.05)), "start": point(INF, 0, 0)}, never_ok, ["start"]),
        ("select_object NaN", S + "select_object", SelectObject, stamped(NAN, 0, 0), never_ok, ["finite|nan"]),
        ("select_object unknown frame", S + "select_object", SelectObject, stamped(0.7, 0, 0.05, "nowhere"), never_ok,
         ["nowhere"]),
        ("select_object 5 m away", S + "select_object", SelectObject, stamped(5, 5, 5), refused, []),
        ("remove_observations batch 999999", G + "remove_observations", RemoveObservations, {"batch_ids": [999999]},
         never_ok, ["999999"]),
        ("remove_observations last 1000000", G + "remove_observations", RemoveObservations, {"last": 1000000},
         refused, []),
        ("add_observations NaN contact", G + "add_observations", AddObservations,
         {"observations": observations([point(NAN, 0, 0.05)])}, never_ok, ["finite|nan"]),
        ("add_observations contact 100 m away", G + "add_observations", AddObservations,
         {"observations": observations([point(100, 0, 0.05)])}, never_ok, ["workspace|outside"]),
        ("add_observations 2 contacts, 1 normal", G + "add_observations", AddObservations,
         {"observations": observations([point(0.6, 0, 0.05)] * 2, [Vector3(-1, 0, 0)])}, never_ok, ["normal"]),
        ("add_observations unknown frame", G + "add_observations", AddObservations,
         {"observations": _in_frame(observations([point(0.6, 0, 0.05)]), "nowhere")}, never_ok, ["nowhere"]),
        ("save_map into a missing folder", M + "save_map", SaveMap, {"path": "/no_such_dir/hostile.bt"}, never_ok,
         ["/no_such_dir/hostile.bt"]),
        ("gp_model reset twice", G + "reset", Trigger, {}, lambda r: r.success, []),
        ("gp_model reset twice (second)", G + "reset", Trigger, {}, lambda r: r.success, []),
        ("segmentation reset", S + "reset", Trigger, {}, lambda r: r.success, []),
    ]
    for name, service, srv, fields, ok, words in probes:
        if stage == "before":  # no model, map or cloud to check the request against: saying so is the answer
            ok = (lambda r, ok=ok: ok(r) or (not getattr(r, "success", True) and
                                             re.search(r"no (collision map|model|cloud segmented) yet", r.message)))
        if stage == "after" and name.startswith(("gp_model reset", "segmentation reset")):
            continue  # the reset and its late subscribers: late_subscriber_probes
        resp, err = call(service, srv, **fields)
        res.add("b", name + " (%s a model)" % stage if not name.endswith("model") else name,
                *answer_outcome(resp, err, ok, words, msg_or_status))


def never_ok(_):
    return False


def msg_or_status(r):
    return ("status %d: " % r.status if hasattr(r, "status") else "success %s: " % getattr(r, "success", "?")) + \
        getattr(r, "message", "")


def _header(frame):
    from std_msgs.msg import Header
    return Header(frame_id=frame)


def _in_frame(obs, frame):
    obs.header.frame_id = frame
    return obs


def wait_message(topic, msg_type, timeout, ok=lambda m: True):
    """The first message on `topic` (a late subscriber: the latched one) that passes ok, or None."""
    import rospy
    import threading
    got = {}
    done = threading.Event()

    def cb(m):
        if not done.is_set() and ok(m):
            got["m"] = m
            done.set()
    sub = rospy.Subscriber(topic, msg_type, cb)
    done.wait(timeout)
    sub.unregister()
    return got.get("m")


def late_subscriber_probes(res):
    """After gp_model's ~reset, a late subscriber of each output gets an empty one, not the old shape."""
    from sensor_msgs.msg import PointCloud2
    from visualization_msgs.msg import Marker
    from shape_msgs.msg import Mesh
    from gpatlas_msgs.msg import OctomapBinary
    from std_srvs.srv import Trigger
    G, M = "/gpatlas/gp_model/", "/gpatlas/collision_map/"
    outputs = [("~surface", G + "surface", PointCloud2, lambda m: m.width * m.height),
               ("~surface_mesh", G + "surface_mesh", Marker, lambda m: 0 if m.action == Marker.DELETEALL else len(m.points)),
               ("~surface_shape", G + "surface_shape", Mesh, lambda m: len(m.triangles)),
               ("collision_map/octomap_binary", M + "octomap_binary", OctomapBinary, lambda m: len(m.data))]
    # All at once: the collision map builds its OctoMap when someone subscribes.
    import concurrent.futures
    with concurrent.futures.ThreadPoolExecutor(len(outputs)) as pool:
        futures = {name: pool.submit(wait_message, topic, t, 240, lambda m, size=size: size(m) > 0)
                   for name, topic, t, size in outputs}
        before = {name: f.result() for name, f in futures.items()}
    for i in (1, 2):
        resp, err = call(G + "reset", Trigger)
        res.add("b", "gp_model reset (%d of 2) with a model" % i,
                *answer_outcome(resp, err, lambda r: r.success, [], msg_or_status))
    time.sleep(3.0)
    for name, topic, msg_type, size in outputs:
        if before[name] is None:  # the model is there: its output is owed to a late subscriber
            latched = wait_message(topic, msg_type, 5)
            res.add("c", "late subscriber of %s after reset" % name, "wrong",
                    "before the reset, with a model, a late subscriber got %s in 240 s" %
                    ("only an empty one (size %d)" % size(latched) if latched else "nothing"))
            continue
        m = wait_message(topic, msg_type, 15)
        old = size(before[name])
        if m is None:
            res.add("c", "late subscriber of %s after reset" % name, "correct", "nothing latched (was %d)" % old)
        else:
            # The octomap of an empty tree is its header alone: far smaller than the model's.
            empty = size(m) == 0 or (name.startswith("collision") and size(m) < old / 100)
            res.add("c", "late subscriber of %s after reset" % name, "correct" if empty else "wrong",
                    "size %d after reset, %d before" % (size(m), old))


def cloud_msg(points, frame, organized=None):
    import struct
    from sensor_msgs.msg import PointCloud2, PointField
    msg = PointCloud2()
    msg.header.frame_id = frame
    import rospy
    msg.header.stamp = rospy.Time.now()
    msg.height, msg.width = organized if organized else (1, len(points) // 3)
    msg.fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1) for i, n in enumerate("xyz")]
    msg.point_step, msg.row_step = 12, 12 * msg.width
    msg.is_dense = False
    msg.data = struct.pack("<%df" % len(points), *points) if not isinstance(points, bytes) else points
    return msg


def contact_probes(res, launch):
    """Hostile contacts on the topic (with a model): a clear log line; never a dead manager."""
    import rospy
    from gpatlas_msgs.msg import Observations
    contacts = rospy.Publisher("/gpatlas/contacts", Observations, queue_size=1)
    time.sleep(2.0)
    published_probes(res, launch, [
        ("contacts topic: NaN contact", contacts, lambda: observations([point(NAN, 0, 0.05)]), r"finite|nan"),
        ("contacts topic: unknown frame", contacts, lambda: _in_frame(observations([point(0.6, 0, 0.05)]), "nowhere"),
         r"nowhere"),
    ])


def topic_probes(res, launch):
    """Hostile clouds: a clear log line, or the right answer; never a dead manager."""
    import array
    import rospy
    from sensor_msgs.msg import PointCloud2
    pub = rospy.Publisher("/camera/points", PointCloud2, queue_size=1)
    time.sleep(2.0)
    rnd = random.Random(51)
    huge = array.array("f")
    for _ in range(1000000):  # a million points in front of the camera (its z is the optical axis)
        huge.extend((rnd.uniform(-0.4, 0.4), rnd.uniform(-0.3, 0.3), rnd.uniform(0.4, 1.5)))
    probes = [
        ("empty cloud", pub, lambda: cloud_msg([], CAMERA_FRAME), r"empty|no points|0 points|no finite"),
        ("all-NaN 640 x 480 cloud", pub, lambda: cloud_msg([NAN] * (3 * 640 * 480), CAMERA_FRAME, (480, 640)),
         r"finite|nan|no points|empty|no table|no object"),
        ("cloud in an unknown frame", pub, lambda: cloud_msg([0.0, 0.0, 1.0] * 1000, "nowhere"), r"nowhere"),
        ("cloud without z", pub, lambda: _xy_only(), r"field|\bz\b"),
        # No error deserved: the answer is that the pipeline takes it and goes on answering.
        ("huge cloud (1,000,000 points)", pub, lambda: cloud_msg(huge.tobytes(), CAMERA_FRAME, (1, 1000000)), None),
    ]
    published_probes(res, launch, probes)


def published_probes(res, launch, probes):
    from gpatlas_msgs.srv import GetNextTouch
    for name, publisher, make, pattern in probes:
        launch.set_mark()
        publisher.publish(make())
        said = launch.wait_for(pattern, 30, since_mark=True) if pattern else None
        resp, err = call("/gpatlas/atlas_planner/next_touch", GetNextTouch, timeout=180)
        if not node_alive("/gpatlas/gpatlas_manager"):
            res.add("c", name, "crash", "the nodelet manager is gone: " + launch.tail())
        elif resp is None:
            res.add("c", name, "hang" if err.startswith("hang") else "unclear", err)
        elif pattern is None:
            res.add("c", name, "correct", "next_touch then: " + msg_or_status(resp)[:80])
        else:
            res.add("c", name, "refused" if said else "unclear",
                    (said or "no log line matching /%s/" % pattern) + "; next_touch then: " + msg_or_status(resp)[:80])


def _xy_only():
    import struct
    from sensor_msgs.msg import PointCloud2, PointField
    import rospy
    msg = PointCloud2(height=1, width=100, point_step=8, row_step=800, is_dense=True)
    msg.header.frame_id, msg.header.stamp = CAMERA_FRAME, rospy.Time.now()
    msg.fields = [PointField(name=n, offset=4 * i, datatype=PointField.FLOAT32, count=1) for i, n in enumerate("xy")]
    msg.data = struct.pack("<200f", *([0.1] * 200))
    return msg


def publish_recorded_cloud(ros):
    return subprocess.Popen(["rosrun", "gpatlas_ros", "cloud_file_publisher", "_file:=" + PCD, "_frame_id:=" + CAMERA_FRAME,
                             "points:=/camera/points"], stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL,
                            env=ros.env, start_new_session=True)


def model_ready(timeout):
    from gpatlas_msgs.msg import TrainingSet
    return wait_message("/gpatlas/gp_model/training_set", TrainingSet, timeout, lambda m: len(m.points) > 0)


def recorded_cloud_again(res, launch, first):
    """And back: the recorded cloud again gives its model (the pipeline survived the hostile clouds).
    Its model, not the last hostile cloud's (the million points' fit can end after the recorded
    cloud has arrived): the same object's centroid as the first model's, within a centimetre."""
    from gpatlas_msgs.msg import TrainingSet
    seen = []

    def same_object(m):
        seen.append(m)
        c, f = m.centroid, first.centroid
        return len(m.points) > 0 and math.dist((c.x, c.y, c.z), (f.x, f.y, f.z)) < 0.01
    ready = wait_message("/gpatlas/gp_model/training_set", TrainingSet, 300, same_object)
    if ready:
        res.add("c", "the recorded cloud again after the hostile ones", "correct",
                "%d training points (the first model: %d)" % (len(ready.points), len(first.points)))
    else:
        last = seen[-1] if seen else None
        res.add("c", "the recorded cloud again after the hostile ones", "hang",
                "no model of the recorded cloud's object in 300 s; the last: %s; %s" %
                ("%d points, centroid (%.2f %.2f %.2f)" % (len(last.points), last.centroid.x, last.centroid.y,
                                                         last.centroid.z) if last else "none", launch.tail()))


def probes_pipeline(res, ros, categories):
    launch = ros.launch(["gpatlas_ros", "recorded_cloud.launch", "camera_pose:=" + CAMERA_POSE, "frame_id:=" + CAMERA_FRAME])
    camera = None
    try:
        import rospy
        rospy.wait_for_service("/gpatlas/atlas_planner/next_touch", timeout=120)
        if "b" in categories:
            service_probes(res, "before")
        camera = publish_recorded_cloud(ros)
        first = model_ready(300)
        if first is None:
            res.add("b", "a model from the recorded cloud", "hang", launch.tail())
            return
        if "b" in categories:
            service_probes(res, "after")
        if "c" in categories:
            contact_probes(res, launch)
            late_subscriber_probes(res)
            topic_probes(res, launch)
            camera.kill()
            camera.wait()
            camera = publish_recorded_cloud(ros)
            recorded_cloud_again(res, launch, first)
    finally:
        if camera:
            camera.kill()
            camera.wait()
        launch.stop()


# ----------------------------------------------------------------------------------------------
# (e) a node killed mid-exploration, (f) a wait nobody answers: the simulated exploration
def sim_exploration(ros, tmp, replace=None):
    src = os.path.join(REPO, "catkin_ws", "src", "probe_sim_ros", "launch", "sim_exploration.launch")
    args = ["max_actions:=40", "v_max:=0.001", "required:=false", "results_dir:=" + os.path.join(tmp, "results")]
    if replace:
        with open(src) as f:
            text = f.read()
        assert replace[0] in text, replace
        src = os.path.join(tmp, "sim_exploration_hostile.launch")
        with open(src, "w") as f:
            f.write(text.replace(*replace))
    return ros.launch([src] + args)


def kill_node(name):
    """SIGKILL a node by its pid (from its own XML-RPC API): no chance to say goodbye."""
    import rosgraph
    import xmlrpc.client
    api = rosgraph.Master("/hostile_probes").lookupNode(name)
    pid = xmlrpc.client.ServerProxy(api).getPid("/hostile_probes")[2]
    os.kill(pid, signal.SIGKILL)
    return pid


def exploration_alive():
    return node_alive("/gpatlas/exploration")


def probes_kill(res, ros, tmp):
    from gpatlas_msgs.srv import GetNextTouch
    # The probe driver killed after the second action: the exploration ends naming the probe service.
    launch = sim_exploration(ros, tmp)
    try:
        if not launch.wait_for(r"exploration: action +2:", 400):
            res.add("e", "probe_sim killed mid-exploration", "hang", "no second action: " + launch.tail())
            return
        launch.set_mark()
        kill_node("/probe_sim")
        end = time.time() + 180
        while time.time() < end and exploration_alive():
            time.sleep(2.0)
        manager = node_alive("/gpatlas/gpatlas_manager")
        said = re.search(r"exploration finished: error.*probe.*", launch.since_mark(), re.I)
        if not manager:
            res.add("e", "probe_sim killed mid-exploration", "crash", "nodelet manager gone")
        elif exploration_alive():
            res.add("e", "probe_sim killed mid-exploration", "hang", "exploration still running 180 s later: " +
                    launch.tail())
        else:
            res.add("e", "probe_sim killed mid-exploration", "refused" if said else "unclear",
                    said.group(0) if said else launch.since_mark()[-200:])
    finally:
        launch.stop()
    # The exploration node killed: the pipeline goes on answering.
    launch = sim_exploration(ros, tmp)
    try:
        if not launch.wait_for(r"exploration: action +2:", 400):
            res.add("e", "exploration_node killed mid-exploration", "hang", "no second action: " + launch.tail())
            return
        kill_node("/gpatlas/exploration")
        resp, err = call("/gpatlas/atlas_planner/next_touch", GetNextTouch, timeout=180)
        res.add("e", "exploration_node killed mid-exploration", *answer_outcome(
            resp, err, lambda r: r.status in (TOUCH, CONVERGED, CAP), [], lambda r: "next_touch after: " + msg_or_status(r)))
    finally:
        launch.stop()


def probes_waits(res, ros, tmp):
    # No collision map status ever: the exploration must say what it waits for (every 10 s).
    launch = sim_exploration(ros, tmp, ('to="/gpatlas/collision_map/status"', 'to="/hostile/no_status"'))
    try:
        if not launch.wait_for(r"exploration: initial model", 400):
            res.add("f", "exploration without collision_map_status", "hang", "no model: " + launch.tail())
            return
        said = launch.wait_for(r"(no_status|collision_map_status|collision map).*", 60)
        said = said if said and re.search(r"wait", said, re.I) else None
        res.add("f", "exploration without collision_map_status", "correct" if said else "hang",
                said or "60 s without a line naming the status it waits for")
    finally:
        launch.stop()
    # No capture service: the exploration says which service it waits for, and gives up.
    launch = sim_exploration(ros, tmp, ('to="/probe_sim/capture"', 'to="/hostile/no_capture"'))
    try:
        said = launch.wait_for(r"waiting.*/hostile/no_capture.*", 120)
        res.add("f", "exploration without a capture service", "correct" if said else "hang",
                said or "120 s without a line naming the service it waits for")
    finally:
        launch.stop()


def main():
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--only", default=",".join(CATEGORIES), help="categories, e.g. a,d (default: all)")
    parser.add_argument("--table", help="also write the table (markdown) to this file")
    parser.add_argument("--keep", action="store_true", help="keep the temporary folder (files, launch logs)")
    args = parser.parse_args()
    categories = set(args.only.split(","))
    if not os.path.exists(PCD) or not os.path.exists(MM_MESH):
        print("hostile_probes: skipped: %s (the recorded cloud, the scanned meshes) is absent" % SHARED)
        return 0
    if shutil.which("rosrun") is None or "ROS_PACKAGE_PATH" not in os.environ:
        print("hostile_probes: source catkin_ws/devel/setup.bash first", file=sys.stderr)
        return 2
    tmp = tempfile.mkdtemp(prefix="hostile_probes_")
    res, ros, start = Results(), Ros(tmp), time.time()
    try:
        if "a" in categories:
            probes_files(res, tmp, write_bad_files(tmp), ros)
        if "d" in categories:
            probes_bench_flags(res, tmp)
        if categories & {"b", "c"}:
            probes_pipeline(res, ros, categories)
        if "e" in categories:
            probes_kill(res, ros, tmp)
        if "f" in categories:
            probes_waits(res, ros, tmp)
    finally:
        ros.stop()
        if not args.keep:
            shutil.rmtree(tmp, ignore_errors=True)
    table = res.table()
    print("\n%s\n\n%.0f s; temporary files %s" % (table, time.time() - start, tmp if args.keep else "removed"))
    if args.table:
        with open(args.table, "w") as f:
            f.write(table + "\n")
    return 1 if any(r[2] in ("wrong", "crash", "hang") for r in res.rows) else 0


if __name__ == "__main__":
    sys.exit(main())
