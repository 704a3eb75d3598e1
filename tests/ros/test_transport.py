#!/usr/bin/python3
"""rost_node's image subscription: ~image_transport, and ~compressed, its
deprecated alias, on a private ROS master.

Three nodes side by side, each fed synthetic images by a rospy publisher
until its first ~frame comes:
- raw (no parameter): sensor_msgs/Image on the image topic;
- `_image_transport:=compressed`: sensor_msgs/CompressedImage (PNG) on
  <image>/compressed, and nothing subscribed on <image> itself;
- `_compressed:=true` (deprecated): CompressedImage on the image topic as
  before, with a warning naming ~image_transport;
- `_topics_grow:=true _K:=32 _frame_width:=128` (the height follows the
  images' aspect ratio): then paused, its topic model's rows are in
  label order through ~get_topic_model and ~set_topic_model (a prior in the
  last row comes back right after the open topics); then, with
  ~use_global_model and a lifting published by hand, ~global_frame lifts
  that topic through its slot, not its label.
Then the mistakes, each fatal at start-up (exit 2) naming the parameter: a
transport no plugin provides, ~compressed disagreeing with ~image_transport,
an ~image_transport that is not a name.

Usage: test_transport.py BUILD_DIR
"""
import os
import subprocess
import sys
import time

from roshelp import Procs, check, main, image_msg, private_master, textured, wait_until

W, H = 256, 192

build = sys.argv[1]
work = os.path.join(build, "ros-test-transport")
os.makedirs(work, exist_ok=True)
procs = Procs(work)
node_bin = os.path.join(build, "rost_node")


def compressed_msg(bgr, i):
    import cv2
    from sensor_msgs.msg import CompressedImage
    ok, png = cv2.imencode(".png", bgr)
    assert ok
    m = CompressedImage(format="png", data=png.tobytes())
    m.header = image_msg(bgr, 10**9 + i).header
    return m


def subscribers(topic):
    import rosgraph.masterapi
    _, subs, _ = rosgraph.masterapi.Master("/rost_transport_test").getSystemState()
    return sorted(n for t, nodes in subs if t == topic for n in nodes)


def fatal(name, params):
    """rost_node with these parameters: its exit code and output (it must stop at start-up)."""
    p = subprocess.run([node_bin, "__name:=" + name, "image:=/cam/none"] + params, stdout=subprocess.PIPE,
                       stderr=subprocess.STDOUT, env=os.environ, timeout=60)
    return p.returncode, p.stdout.decode(errors="replace")


def topic_model_rows_in_label_order(node):
    """With growth, ~get_topic_model's and ~set_topic_model's row k is the topic ~frame labels k: a
    prior set in the last row (a slot above the open ones) comes back right after the open topics."""
    import rospy
    from rost_msgs.srv import GetTopicModel, SetTopicModel
    from std_srvs.srv import SetBool
    rospy.ServiceProxy(node + "/pause", SetBool)(True)
    get = rospy.ServiceProxy(node + "/get_topic_model", GetTopicModel)
    m = get()
    K, V = m.K, m.V
    rows = [list(m.counts[k * V:(k + 1) * V]) for k in range(K)]
    A = sum(1 for r in rows if any(r))
    check(0 < A < K - 1 and all(any(r) for r in rows[:A]),
          "%s: the %d open topics of %d are rows 0..%d" % (node, A, K, A - 1))
    prior = [0] * (K * V)
    prior[(K - 1) * V + 3] = 5000
    ok = rospy.ServiceProxy(node + "/set_topic_model", SetTopicModel)(K, V, prior)
    check(ok.success, "%s: ~set_topic_model with a prior in row %d: %s" % (node, K - 1, ok.message))
    m = get()
    rows = [list(m.counts[k * V:(k + 1) * V]) for k in range(K)]
    nonzero = [k for k in range(K) if any(rows[k])]
    check(nonzero == list(range(A + 1)) and rows[A][3] == 5000 and sum(rows[A]) == 5000,
          "%s: the prior's topic is the next label, row %d (rows holding words: %s)" % (node, A, nonzero))
    return A


def global_frame_through_slots(node, A, pub, got, globals_):
    """~global_frame with growth reads the lifting through each frame's slots: the prior's topic
    sits in slot K-1, above closed slots (its label is the last open one, A' - 1), so a lifting
    that sends slot k to global topic k gives it global topic K-1, where a lifting read by label
    would give A' - 1. A wider prior on that topic (30 of every word) makes the frames use it."""
    import rospy
    from rost_msgs.msg import TopicLifting, VehicleLifting
    from rost_msgs.srv import GetTopicModel, SetTopicModel
    from std_srvs.srv import SetBool
    m = rospy.ServiceProxy(node + "/get_topic_model", GetTopicModel)()
    K, V = m.K, m.V
    wide = [0] * (K * V)
    for v in range(5000, 5256):  # the intensity words (V = 5436: ORB 5000, intensity 256, hue 180)
        wide[A * V + v] = 200
    check(rospy.ServiceProxy(node + "/set_topic_model", SetTopicModel)(K, V, wide).success,
          "%s: ~set_topic_model: 30 of every word to the prior's topic (row %d)" % (node, A))
    lifting = rospy.Publisher("/grow_lifting", TopicLifting, queue_size=1, latch=True)
    wait_until(lambda: lifting.get_num_connections() > 0, 15)
    lifting.publish(TopicLifting(G=K, vehicles=[VehicleLifting(vehicle=node.lstrip("/"), global_=list(range(K)))]))
    rospy.ServiceProxy(node + "/pause", SetBool)(False)
    images = [textured(W, H, i) for i in range(4)]
    frame_of = {}

    def pairs():
        for f in got:
            frame_of[f.header.stamp.to_nsec()] = f
        return [(frame_of[g.header.stamp.to_nsec()], g) for g in globals_
                if g.active_topics == K and g.header.stamp.to_nsec() in frame_of]

    def beyond_labels(pair):  # a global topic past the frame's labels: a slot that is not its label
        f, g = pair
        return any(w > 0 for w in g.topic_weights[f.active_topics:])

    # Growth may close the prior's topic again (a merge into slot 0) after a
    # frame or two: frames are taken while some of them lie above closed slots.
    def lifted():
        pub.publish(image_msg(images[int(time.time() * 10) % 4], int(time.time() * 1e9)))
        return any(beyond_labels(p) for p in pairs())

    wait_until(lifted, 60, step=0.3)
    found = pairs()
    check(found, "%s: ~global_frame in the lifting's %d topics for a frame" % (node, K))
    # The lifting sends slot k to global topic k, and a frame's labels are its open slots in
    # increasing order: each frame's weights land, in order, on its open slots; a frame whose
    # open slots are not 0..a-1 shows it (read by label they would land on 0..a-1).
    def in_order(pair):
        f, g = pair
        return [w for w in g.topic_weights if w > 0] == [w for w in f.topic_weights if w > 0]

    wrong = [p for p in found if not in_order(p)]
    check(not wrong, "%s: each of %d frames' weights lifted in order to its open slots%s" % (
        node, len(found), "" if not wrong else ": not %s -> %s" % (
            [round(w, 3) for w in wrong[0][0].topic_weights], [round(w, 3) for w in wrong[0][1].topic_weights])))
    beyond = [p for p in found if beyond_labels(p)]
    check(beyond, "%s: a frame with a topic above closed slots (the prior's, in slot %d) lifted by its slot, "
          "past its %d labels (frames: %s)" % (node, K - 1, found[-1][0].active_topics,
                                               [[round(w, 3) for w in g.topic_weights] for _, g in found[-3:]]))


def run():
    private_master(procs)
    import rospy
    from rost_msgs.msg import FrameTopics
    from sensor_msgs.msg import CompressedImage, Image
    rospy.init_node("rost_transport_test", anonymous=True, disable_signals=True)
    # name: (node parameters, topic published, message type)
    cases = {
        "rost_raw": (["image:=/cam/raw"], "/cam/raw", Image),
        "rost_compressed": (["image:=/cam/png", "_image_transport:=compressed"], "/cam/png/compressed", CompressedImage),
        "rost_alias": (["image:=/cam/old", "_compressed:=true"], "/cam/old", CompressedImage),
        "rost_grow": (["image:=/cam/grow", "_topics_grow:=true", "_K:=32", "_frame_width:=128",
                       "_use_global_model:=true", "lifting:=/grow_lifting"], "/cam/grow", Image),
    }
    got, pubs, nodes, grow_globals = {}, {}, {}, []
    rospy.Subscriber("/rost_grow/global_frame", FrameTopics, grow_globals.append, queue_size=100)
    for name, (params, topic, kind) in cases.items():
        got[name] = []
        rospy.Subscriber("/%s/frame" % name, FrameTopics, got[name].append, queue_size=100)
        pubs[name] = rospy.Publisher(topic, kind, queue_size=10)
        nodes[name] = procs.start([node_bin, "__name:=" + name, "_budget_refines:=2"] + params, name + ".log")
    images = [textured(W, H, i) for i in range(4)]

    def feed():
        """One image to each node still waiting; true once every node has published a frame."""
        for name, (_, _, kind) in cases.items():
            if not got[name] and pubs[name].get_num_connections() > 0:
                i = int(time.time() * 10) % len(images)
                pubs[name].publish(image_msg(images[i], 10**9 + i) if kind is Image else compressed_msg(images[i], i))
        return all(got.values()) or any(p.poll() is not None for p in nodes.values())

    wait_until(feed, 90, step=0.2)
    for name in cases:
        check(nodes[name].poll() is None and got[name], "%s: a ~frame from the images on %s (%s)" %
              (name, cases[name][1], cases[name][2].__name__))
    check(subscribers("/cam/png") == [] and subscribers("/cam/png/compressed") == ["/rost_compressed"],
          "_image_transport:=compressed subscribes <image>/compressed only")
    A = topic_model_rows_in_label_order("/rost_grow")
    global_frame_through_slots("/rost_grow", A, pubs["rost_grow"], got["rost_grow"], grow_globals)
    for p in nodes.values():
        Procs.stop(p)
    logs = {name: procs.log(name + ".log") for name in cases}
    check("(raw transport)" in logs["rost_raw"] and "deprecated" not in logs["rost_raw"], "no parameter: raw")
    check("frames of 128x96," in logs["rost_grow"],
          "~frame_width:=128 alone keeps the 256x192 images' aspect ratio: frames of 128x96")
    check("(compressed transport, decoded by rost_node)" in logs["rost_compressed"] and
          "deprecated" not in logs["rost_compressed"], "compressed: rost_node decodes them (no plugin installed)")
    check("~compressed is deprecated" in logs["rost_alias"] and "use ~image_transport" in logs["rost_alias"] and
          "listening on /cam/old (compressed transport" in logs["rost_alias"],
          "~compressed:=true: CompressedImage on the image topic, with a warning naming ~image_transport")

    code, out = fatal("rost_theora", ["_image_transport:=theora"])
    check(code == 2 and "~image_transport = theora: no image_transport plugin provides it" in out and "raw" in out and
          "listening" not in out, "a transport no plugin provides: exit %s, named with those installed" % code)
    code, out = fatal("rost_clash", ["_image_transport:=raw", "_compressed:=true"])
    check(code == 2 and "~compressed = true and ~image_transport = raw disagree" in out,
          "~compressed:=true with ~image_transport:=raw: exit %s, both named" % code)
    code, out = fatal("rost_number", ["_image_transport:=5"])
    check(code == 2 and "~image_transport: expected the name of a transport" in out,
          "~image_transport:=5: exit %s, named" % code)


main(run, procs)
