#!/usr/bin/python3
"""rost.launch through roslaunch, as a ROS user runs it, on a private roscore.

Starts `roscore` on a free loopback port, writes a bag of synthetic images,
then:
1. leaves a stale private parameter on the parameter server (`rosparam set
   /rost/image_transport compressed`, as an earlier run would), launches
   `roslaunch rost rost.launch image:=... K:=8 checkpoint:=... params:=YAML`,
   plays the bag and checks that ~frame comes for every image with 8 topics
   (the launch file's clear_params dropped the stale parameter: the node
   subscribes raw images), that the YAML's parameter is set (rosparam get),
   that rosnode lists the node, and that stopping roslaunch leaves the final
   checkpoint;
2. leaves a stale `/rost/K` of 16, launches with `resume:=` that checkpoint
   and no K, plays the bag again and checks that the resumed mission keeps
   its K of 8 (the launch file passes no K it was not given) and numbers its
   frames after the checkpoint's.

Usage: test_launch.py BUILD_DIR
"""
import os
import subprocess
import sys

from roshelp import Procs, check, main, frames_until, image_msg, private_master, textured, wait_until

N = 8
W, H = 320, 240
STAMP0 = 1700000000 * 10**9

build = sys.argv[1]
work = os.path.join(build, "ros-test-launch")
os.makedirs(work, exist_ok=True)
procs = Procs(work)


def write_bag(path):
    import rosbag
    import rospy
    stamps = []
    with rosbag.Bag(path, "w") as bag:
        for i in range(N):
            m = image_msg(textured(W, H, i), STAMP0 + i * 100000000)
            m.header.seq = i
            bag.write("/cam/image", m, rospy.Time(0) + rospy.Duration(1 + i * 0.1))
            stamps.append(m.header.stamp.to_nsec())
    return stamps


def rosparam(*args):
    return subprocess.run(["rosparam"] + list(args), check=True, stdout=subprocess.PIPE, env=os.environ,
                          timeout=30).stdout.decode().strip()


def launch(log, args, stamps):
    """roslaunch rost rost.launch ARGS, the bag played once: the ~frame messages and roslaunch's process."""
    import rospy
    from rost_msgs.msg import FrameTopics
    got = []
    sub = rospy.Subscriber("/rost/frame", FrameTopics, lambda m: got.append(m), queue_size=1000)
    p = procs.start(["roslaunch", "--screen", "rost", "rost.launch"] + args, log)
    # The bag plays once the node subscribes to the images and this process to
    # its ~frame (or a first ~frame could go unseen); a node that exits stops
    # the wait. --keep-alive: a player that exits may take its last, still
    # unsent image with it under load; it is stopped once the images are in.
    wait_until(lambda: sub.get_num_connections() > 0 or p.poll() is not None, 90)
    player = procs.start(["rosbag", "play", "--wait-for-subscribers", "--keep-alive", "-q", bag], log + ".rosbag")
    frames_until(got, len(stamps), p)
    Procs.stop(player)
    sub.unregister()
    return got, p


def stop_launch(p):
    Procs.stop(p, timeout=30)
    check(p.returncode == 0, "roslaunch stops on SIGINT with exit 0 (its node too)")


def run():
    global bag
    private_master(procs, "roscore")
    bag = os.path.join(work, "synthetic.bag")
    stamps = write_bag(bag)
    import rospy
    rospy.init_node("rost_launch_test", anonymous=True, disable_signals=True)

    ckpt = os.path.join(work, "launch.ckpt")
    if os.path.exists(ckpt):
        os.remove(ckpt)
    yaml = os.path.join(work, "params.yaml")
    with open(yaml, "w") as f:
        f.write("budget_refines: 4\nqueue_slots: 64\nimage_queue: 64\n")  # every image modelled, however loaded
    rosparam("set", "/rost/image_transport", "compressed")  # as an earlier run would leave it
    got, p = launch("launch1.log", ["image:=/cam/image", "K:=8", "checkpoint:=" + ckpt, "params:=" + yaml], stamps)
    check(p.poll() is None, "roslaunch runs rost_node")
    check([m.header.stamp.to_nsec() for m in got] == stamps,
          "~frame for every image of the bag, stamped like it (%d of %d)" % (len(got), len(stamps)))
    check([m.frame for m in got] == list(range(N)), "~frame numbers the images from 0: %s" % [m.frame for m in got])
    check(all(m.active_topics == 8 and len(m.topic_weights) == 8 for m in got), "K:=8 reaches the node: 8 topics")
    check(rosparam("get", "/rost/budget_refines") == "4", "params:=FILE loads its parameters (rosparam get: 4)")
    check(rosparam("list", "/rost").split().count("/rost/image_transport") == 0,
          "clear_params: the stale ~image_transport is gone, the node subscribes raw images")
    nodes = subprocess.run(["rosnode", "list"], stdout=subprocess.PIPE, env=os.environ, timeout=30).stdout.decode()
    check("/rost" in nodes.split(), "rosnode list shows /rost")
    stop_launch(p)
    with open(ckpt, "rb") as f:
        check(f.read(8) == b"ROSTCKPT", "stopping roslaunch leaves the final checkpoint " + ckpt)

    rosparam("set", "/rost/K", "16")  # a stale K: the launch file must neither keep it nor pass one
    queues = os.path.join(work, "queues.yaml")
    with open(queues, "w") as f:
        f.write("queue_slots: 64\nimage_queue: 64\n")  # every image modelled, however loaded
    got, p = launch("launch2.log", ["image:=/cam/image", "resume:=" + ckpt, "params:=" + queues], stamps)
    check(p.poll() is None and len(got) == len(stamps),
          "resume:= through the launch file runs (%d of %d frames)" % (len(got), len(stamps)))
    # The mission's frames are numbered on after the checkpoint's, as `rost run
    # --resume` numbers a camera's; `dropped` counts this node's images only.
    check([m.frame for m in got] == list(range(N, 2 * N)) and all(m.dropped == 0 for m in got),
          "the resumed node numbers its images after the checkpoint's %d: %s, dropped %s" %
          (N, [m.frame for m in got], [m.dropped for m in got]))
    stop_launch(p)
    log = procs.log("launch2.log")  # whole once roslaunch is gone
    check(all(m.active_topics == 8 for m in got) and "K = 8, V = " in log and "resumed from " + ckpt in log,
          "the resumed mission keeps its checkpoint's K of 8 (topics per frame: %s)" %
          sorted(set(m.active_topics for m in got)))


main(run, procs)
