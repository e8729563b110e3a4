#!/usr/bin/env python3
"""The bounded soak: waits for the exploration's report while sampling the nodelet manager's
memory, then checks that the per-action wall time does not grow and prints where it goes."""
import json
import os
import shutil
import statistics
import time
import unittest
import xmlrpc.client

import rosgraph
import rospy
import rostest

MANAGER = "/gpatlas/gpatlas_manager"


def manager_pid():
    master = rosgraph.Master("/test_soak")
    try:
        uri = master.lookupNode(MANAGER)
        _, _, pid = xmlrpc.client.ServerProxy(uri).getPid("/test_soak")
        return pid
    except Exception:  # not up yet
        return None


def rss_mb(pid):
    try:
        with open("/proc/%d/status" % pid) as f:
            for line in f:
                if line.startswith("VmRSS:"):
                    return int(line.split()[1]) / 1024.0
    except OSError:
        return None
    return None


def breakdown(history):
    """Mean milliseconds per action of each step, and what is left (waits, measurements)."""
    keys = ("action_ms", "plan_ms", "probe_ms", "update_ms")
    means = {k: statistics.mean(h[k] for h in history) for k in keys}
    means["other_ms"] = means["action_ms"] - means["plan_ms"] - means["probe_ms"] - means["update_ms"]
    return means


class SoakTest(unittest.TestCase):
    def test_wall_time_does_not_grow(self):
        results = rospy.get_param("~results_dir")
        max_actions = rospy.get_param("~max_actions")
        report_path = os.path.join(results, "report.json")
        budget_s = 60.0 + 10.0 * max_actions
        deadline = time.time() + budget_s
        pid, rss = None, []
        while not os.path.exists(report_path) and time.time() < deadline and not rospy.is_shutdown():
            pid = pid or manager_pid()
            if pid:
                sample = rss_mb(pid)
                if sample is not None:
                    rss.append(sample)
            time.sleep(1.0)
        self.assertTrue(os.path.exists(report_path), "no report.json after %.0f s" % budget_s)
        time.sleep(1.0)
        with open(report_path) as f:
            report = json.load(f)
        history = report["history"]
        self.assertEqual(report["stop_reason"], "max_actions", report["stop_reason"])
        self.assertEqual(len(history), max_actions)
        first, last = breakdown(history[:10]), breakdown(history[-10:])
        print("\nsoak, mean ms per action (first 10 / last 10):")
        for key in ("action_ms", "plan_ms", "probe_ms", "update_ms", "other_ms"):
            print("  %-10s %8.0f %8.0f" % (key, first[key], last[key]))
        if rss:
            print("  manager RSS: %.0f MB at the first sample, %.0f MB at the end, peak %.0f MB"
                  % (rss[0], rss[-1], max(rss)))
        # make test runs two tests at a time, so there the wall time measures the neighbour too:
        # the time check is make soak's (check_wall_time), on an otherwise idle machine.
        if rospy.get_param("~check_wall_time", False):
            self.assertLessEqual(last["action_ms"], 1.5 * first["action_ms"],
                                 "per-action wall time grew from %.0f ms to %.0f ms"
                                 % (first["action_ms"], last["action_ms"]))
        # What does not depend on the load: every action is timed, and the model grows by at most
        # one capped touch per action (touch/max_contacts_per_touch 500, each with a point behind
        # it and two tangent slopes at most; max_free_space_per_touch 1000).
        for h in history:
            self.assertGreater(h["action_ms"], 0.0)
        for a, b in zip(history, history[1:]):
            self.assertLessEqual(b["n_train"] - a["n_train"], 4 * 500 + 1000)
        shutil.rmtree(results, ignore_errors=True)


if __name__ == "__main__":
    rospy.init_node("test_soak")
    rostest.rosrun("probe_sim_ros", "soak_test", SoakTest)
