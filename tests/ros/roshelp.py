"""What the ROS tests share: a private ROS master on a free loopback port,
processes started in their own session and stopped by their PID, waiting on
a condition, checks that print what they found.

ROS_MASTER_URI, ROS_IP, ROS_HOME and ROS_LOG_DIR are set for this process
and every one it starts, so tests run side by side (ctest -j) each on its
own master.
"""
import os
import signal
import socket
import subprocess
import time


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def check(cond, what):
    if not cond:
        raise AssertionError(what)
    print("ok:", what)


def wait_until(cond, timeout, step=0.1):
    """Polls cond() until it holds or `timeout` seconds pass; its last value."""
    end = time.time() + timeout
    while True:
        got = cond()
        if got or time.time() > end:
            return got
        time.sleep(step)


class Procs:
    """Processes started with their output in WORK/LOG, stopped (SIGINT, then
    SIGKILL) by their PID, in reverse order, by stop_all."""

    def __init__(self, work):
        self.work = work
        self.procs = []

    def start(self, cmd, log):
        p = subprocess.Popen(cmd, stdout=open(os.path.join(self.work, log), "w"), stderr=subprocess.STDOUT,
                             env=os.environ, start_new_session=True)
        self.procs.append(p)
        return p

    def log(self, name):
        with open(os.path.join(self.work, name), errors="replace") as f:
            return f.read()

    @staticmethod
    def stop(p, timeout=10):
        if p.poll() is None:
            os.kill(p.pid, signal.SIGINT)
            try:
                p.wait(timeout=timeout)
            except subprocess.TimeoutExpired:
                os.kill(p.pid, signal.SIGKILL)
                p.wait()

    def stop_all(self):
        for p in reversed(self.procs):
            self.stop(p)


def private_master(procs, command="rosmaster"):
    """Starts `rosmaster --core` (or `roscore`) on a free port, with this
    process's ROS environment pointing at it; waits until it answers."""
    import rosgraph
    for attempt in range(3):
        # The port is free now; a process of a test running beside this one
        # may take it before the master binds it. The master then exits (and
        # what answers is not it): another port.
        port = free_port()
        os.environ.update(ROS_MASTER_URI="http://127.0.0.1:%d" % port, ROS_IP="127.0.0.1",
                          ROS_HOME=os.path.join(procs.work, "ros_home"),
                          ROS_LOG_DIR=os.path.join(procs.work, "ros_log"))
        os.environ.pop("ROS_HOSTNAME", None)
        cmd = ["rosmaster", "--core", "-p", str(port)] if command == "rosmaster" else ["roscore", "-p", str(port)]
        master = procs.start(cmd, "%s%s.log" % (command, "-%d" % attempt if attempt else ""))
        online = wait_until(lambda: master.poll() is not None or rosgraph.is_master_online(), 30)
        if online and master.poll() is None and not wait_until(lambda: master.poll() is not None, 1):
            break
        Procs.stop(master)
    check(master.poll() is None and rosgraph.is_master_online(), "%s answers on 127.0.0.1:%d" % (command, port))
    return port


def textured(width, height, seed):
    """A BGR image (numpy, height x width x 3) of random 8-pixel blocks:
    corners everywhere, so the word extractors find words in it."""
    import numpy as np
    rng = np.random.default_rng(seed)
    blocks = rng.integers(0, 256, size=((height + 7) // 8, (width + 7) // 8, 3), dtype=np.uint8)
    return np.ascontiguousarray(blocks.repeat(8, axis=0).repeat(8, axis=1)[:height, :width])


def image_msg(bgr, stamp_ns, frame_id="camera"):
    import rospy
    from sensor_msgs.msg import Image
    h, w = bgr.shape[:2]
    m = Image(height=h, width=w, encoding="bgr8", step=w * 3, data=bgr.tobytes())
    m.header.stamp = rospy.Time(stamp_ns // 10**9, stamp_ns % 10**9)
    m.header.frame_id = frame_id
    return m


def frames_until(got, n, node, quiet=10, first=60):
    """Waits while `got` (a list a subscriber appends to) grows towards n:
    `first` seconds for the first message (a loaded machine starts a node
    slowly), then `quiet` seconds without a new one at most; stops early
    when `node` (a Popen) exits. The number received."""
    quiet_since, seen = time.time(), -1
    while len(got) < n and time.time() < quiet_since + (quiet if got else first) and node.poll() is None:
        if len(got) != seen:
            quiet_since, seen = time.time(), len(got)
        time.sleep(0.1)
    return len(got)


def main(run, procs):
    """Runs the test `run`; then stops every process it started, pass or fail."""
    start = time.time()
    try:
        run()
        print("1 passed, 0 failed (%.1f s)" % (time.time() - start))
    finally:
        procs.stop_all()
