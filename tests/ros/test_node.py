#!/usr/bin/python3
"""rost_node end to end, on a private ROS master.

Starts `rosmaster --core` on a free loopback port (ROS_MASTER_URI on
127.0.0.1, ROS_IP=127.0.0.1, ROS_HOME in the build tree), writes a bag of real
footage with a hard cut (mire-2, then diver.mov: the scene change of
tests/test_vision_curiosity.cpp), starts rost_node, plays the bag with
`rosbag play --wait-for-subscribers`, and checks with a rospy subscriber that
~frame arrives for every image with the image's stamp and frame_id, and that
surprise peaks at the cut; ~topic_map, ~surprise_map, ~perplexity and
~surprise carry each frame's cells and numbers, and a frame's perplexity after
refinement is below its surprise. Then the services: pause, get_topic_model,
set_topic_model (a mismatched K is refused), save_checkpoint. Then a bad
parameter: rost_node exits non-zero naming it. Every process started here
is stopped by its PID.

Usage: test_node.py BUILD_DIR FOOTAGE_DIR
"""
import os
import signal
import subprocess
import sys
import time

from roshelp import Procs, check, main, private_master, wait_until

PER_SCENE = 16
WARM_UP = 6
W, H = 384, 288
STAMP0 = 1700000000  # seconds; the bag's images are stamped 0.1 s apart from here
FRAME_ID = "camera_optical"

build, footage = sys.argv[1], sys.argv[2]
if not os.path.isdir(os.path.join(footage, "pd-extendedview")) or not os.path.isdir(
        os.path.join(footage, "visp-images-data")):
    if os.environ.get("CI") == "true":
        sys.exit("no footage in %s" % footage)
    print("skipped: no footage (scripts/fetch-footage.sh visp-images-data pd-extendedview)")
    sys.exit(77)
work = os.path.join(build, "ros-test")
os.makedirs(work, exist_ok=True)
procs = Procs(work)
start, stop = procs.start, Procs.stop


def frames(source, n):
    """n frames of W x H, BGR bytes, decoded by ffmpeg."""
    raw = subprocess.run(["ffmpeg", "-loglevel", "error", "-i", source, "-frames:v", str(n), "-vf",
                          "scale=%d:%d" % (W, H), "-f", "rawvideo", "-pix_fmt", "bgr24", "-"],
                         check=True, stdout=subprocess.PIPE).stdout
    size = W * H * 3
    out = [raw[i:i + size] for i in range(0, len(raw), size)]
    assert len(out) == n, "%s: %d frames, expected %d" % (source, len(out), n)
    return out


def write_bag(path):
    import rosbag
    import rospy
    from sensor_msgs.msg import Image
    mire = os.path.join(footage, "visp-images-data/usr/share/visp-images-data/ViSP-images/mire-2/image.%04d.pgm")
    diver = os.path.join(footage, "pd-extendedview/usr/share/doc/pd-extendedview/media/diver.mov")
    images = frames(mire, PER_SCENE) + frames(diver, PER_SCENE)
    stamps = []
    with rosbag.Bag(path, "w") as bag:
        # First, an image too small to extract words from: skipped (logged), never sizing the model.
        tiny = Image(height=1, width=1, encoding="bgr8", step=3, data=bytes(3))
        tiny.header.stamp = rospy.Time(STAMP0 - 1, 0)
        bag.write("/camera/image_raw", tiny, tiny.header.stamp)
        for i, data in enumerate(images):
            m = Image(height=H, width=W, encoding="bgr8", step=W * 3, data=data)
            m.header.seq = i
            m.header.stamp = rospy.Time(STAMP0 + i // 10, (i % 10) * 100000000 + 1234)
            m.header.frame_id = FRAME_ID
            bag.write("/camera/image_raw", m, m.header.stamp)
            stamps.append(m.header.stamp.to_nsec())
            if i in (3, 5):  # an image rost cannot read: logged once, then skipped
                bad = Image(height=H, width=W, encoding="bayer_rggb8", step=W, data=bytes(W * H))
                bad.header.stamp = rospy.Time(STAMP0 + 100 + i, 0)
                bag.write("/camera/image_raw", bad, m.header.stamp)
    return stamps


def check_maps(got, topic_maps, surprise_maps, perplexities, surprises):
    """~topic_map, ~surprise_map, ~perplexity and ~surprise against ~frame,
    image by image (matched by stamp; the last ones may be in flight)."""
    import struct
    wait_until(lambda: len(topic_maps) == len(got) and len(surprise_maps) == len(got) and
               len(perplexities) == len(got) and len(surprises) == len(got), 10)
    frame_of = {m.header.stamp.to_nsec(): m for m in got}
    check(len(topic_maps) == len(got) and len(surprise_maps) == len(got),
          "~topic_map and ~surprise_map for every ~frame (%d and %d of %d)" % (len(topic_maps), len(surprise_maps), len(got)))
    colour_of, wrong = {}, []
    for img in topic_maps:
        m = frame_of.get(img.header.stamp.to_nsec())
        if m is None or img.encoding != "rgb8" or (img.width, img.height, img.step) != (m.cells_x * 64, m.cells_y * 64, m.cells_x * 192):
            wrong.append("%s %dx%d" % (img.encoding, img.width, img.height))
            continue
        data = bytes(img.data)
        for cy in range(m.cells_y):
            for cx in range(m.cells_x):
                k = m.cell_topics[cy * m.cells_x + cx]
                rows = {data[y * img.step + cx * 192:y * img.step + (cx + 1) * 192] for y in range(cy * 64, (cy + 1) * 64)}
                px = {r[i:i + 3] for r in rows for i in range(0, 192, 3)}
                if len(px) != 1:
                    wrong.append("frame %d cell (%d, %d): %d colours" % (m.frame, cx, cy, len(px)))
                elif (k < 0) != (px == {bytes(3)}) or colour_of.setdefault(k, px) != px:
                    wrong.append("frame %d cell (%d, %d): topic %d in %s" % (m.frame, cx, cy, k, px))
    colours = [c for k, c in colour_of.items() if k >= 0]
    check(not wrong and len(colours) >= 2 and len(set(map(frozenset, colours))) == len(colours),
          "~topic_map: each frame's cells (64 pixels square) in their topic's colour, one colour a topic (%d topics "
          "seen), black without words %s" % (len(colours), wrong[:3]))
    wrong = []
    for img in surprise_maps:
        m = frame_of.get(img.header.stamp.to_nsec())
        values = struct.unpack("<%df" % (len(img.data) // 4), bytes(img.data))
        if m is None or img.encoding != "32FC1" or (img.width, img.height, img.step) != (m.cells_x, m.cells_y, m.cells_x * 4) \
                or list(values) != list(m.cell_surprise):
            wrong.append(m.frame if m else img.header.stamp.to_nsec())
    check(not wrong and any(v > 0 for m in got for v in m.cell_surprise),
          "~surprise_map: each frame's cell_surprise as a cells_x x cells_y 32FC1 image %s" % wrong[:3])
    check(perplexities == [m.perplexity for m in got] and surprises == [m.surprise for m in got],
          "~perplexity and ~surprise: each frame's numbers, in order")
    # A frame's words fit the model better once they are in it and refined
    # than before (its surprise), and both are perplexities: at least 1.
    ok = [m for m in got[WARM_UP:] if 1 <= m.perplexity < m.surprise]
    check(all(m.perplexity >= 1 for m in got) and len(ok) >= 0.9 * len(got[WARM_UP:]),
          "~frame's perplexity: at least 1, below the frame's surprise in %d of %d frames after the warm-up" %
          (len(ok), len(got[WARM_UP:])))


def run():
    bag = os.path.join(work, "cut.bag")
    stamps = write_bag(bag)
    private_master(procs)

    import rospy

    from rost_msgs.msg import FrameTopics
    rospy.init_node("rost_test", anonymous=True, disable_signals=True)
    got = []
    frame_sub = rospy.Subscriber("/rost/frame", FrameTopics, lambda m: got.append(m), queue_size=1000)
    # The maps (published while someone subscribes) and the simplest consumers' numbers.
    from sensor_msgs.msg import Image
    from std_msgs.msg import Float32
    topic_maps, surprise_maps, perplexities, surprises = [], [], [], []
    side_subs = [rospy.Subscriber("/rost/topic_map", Image, topic_maps.append, queue_size=1000),
                 rospy.Subscriber("/rost/surprise_map", Image, surprise_maps.append, queue_size=1000),
                 rospy.Subscriber("/rost/perplexity", Float32, lambda m: perplexities.append(m.data), queue_size=1000),
                 rospy.Subscriber("/rost/surprise", Float32, lambda m: surprises.append(m.data), queue_size=1000)]

    ckpt = os.path.join(work, "node.ckpt")
    if os.path.exists(ckpt):
        os.remove(ckpt)
    node = start([os.path.join(build, "rost_node"), "__name:=rost", "image:=/camera/image_raw",
                  "_budget_refines:=8", "_queue_slots:=64", "_image_queue:=64",  # every image, however loaded
                  "_checkpoint:=" + ckpt], "rost_node.log")
    # This process's subscription to ~frame connects after the node advertises
    # it: the first image waits for that, or its ~frame could go unseen.
    wait_until(lambda: all(x.get_num_connections() > 0 for x in [frame_sub] + side_subs) or node.poll() is not None, 60)
    # --keep-alive: a player that exits at once may take its last, still unsent
    # image with it (seen under load); it is stopped once every image is in.
    player = start(["rosbag", "play", "--wait-for-subscribers", "--keep-alive", "-q", bag], "rosbag.log")
    # Waits while messages come; before the first one longer (a loaded machine
    # starts the node and its extractors slowly), then 10 s of quiet at most.
    quiet_since, seen = time.time(), -1
    while len(got) < len(stamps) and time.time() < quiet_since + (10 if got else 60) and node.poll() is None:
        if len(got) != seen:
            quiet_since, seen = time.time(), len(got)
        time.sleep(0.1)
    stop(player)
    check(node.poll() is None, "rost_node runs")
    check(len(got) == len(stamps), "~frame for every image (%d of %d)" % (len(got), len(stamps)))
    check([m.header.stamp.to_nsec() for m in got] == stamps, "~frame stamped with the images' stamps, in order")
    check(all(m.header.frame_id == FRAME_ID for m in got), "~frame has the images' frame_id")
    m0 = got[0]
    check(m0.cells_x == (W + 63) // 64 and m0.cells_y == (H + 63) // 64 and len(m0.cell_topics) == m0.cells_x * m0.cells_y,
          "a grid of %dx%d cells" % (m0.cells_x, m0.cells_y))
    check(all(abs(sum(m.topic_weights) - 1) < 1e-3 and len(m.topic_weights) == m.active_topics for m in got),
          "topic weights: K of them, summing to 1")
    sur = [m.surprise for m in got]
    after_warm_up = range(WARM_UP, len(sur))
    peak = max(after_warm_up, key=lambda i: sur[i])
    check(peak == PER_SCENE, "surprise peaks at the cut (frame %d: %.1f; before it at most %.1f)" %
          (peak, sur[peak], max(sur[WARM_UP:PER_SCENE])))

    check_maps(got, topic_maps, surprise_maps, perplexities, surprises)

    from std_srvs.srv import SetBool, Trigger
    from rost_msgs.srv import GetTopicModel, SetTopicModel
    for s in ("/rost/pause", "/rost/get_topic_model", "/rost/set_topic_model", "/rost/save_checkpoint"):
        rospy.wait_for_service(s, timeout=10)
    check(rospy.ServiceProxy("/rost/pause", SetBool)(True).success, "~pause answers")
    model = rospy.ServiceProxy("/rost/get_topic_model", GetTopicModel)()
    check(model.K == m0.active_topics and len(model.counts) == model.K * model.V and sum(model.counts) > 0,
          "~get_topic_model: K = %d, V = %d, %d words counted" % (model.K, model.V, sum(model.counts)))
    bad = rospy.ServiceProxy("/rost/set_topic_model", SetTopicModel)(model.K + 1, model.V, [])
    check(not bad.success and "K = %d" % model.K in bad.message, "~set_topic_model refuses another K: " + bad.message)
    ok = rospy.ServiceProxy("/rost/set_topic_model", SetTopicModel)(model.K, model.V, [0] * (model.K * model.V))
    check(ok.success, "~set_topic_model adds counts of the node's K x V")
    saved = rospy.ServiceProxy("/rost/save_checkpoint", Trigger)()
    check(saved.success and open(ckpt, "rb").read(8) == b"ROSTCKPT", "~save_checkpoint writes " + ckpt)
    stop(node)
    check(node.returncode == 0, "rost_node stops on SIGINT with exit 0")
    log = open(os.path.join(work, "rost_node.log")).read()
    check(log.count("bayer_rggb8") == 1 and "/camera/image_raw" in log,
          "an image rost cannot read is logged once for its topic, and the next ones are read")
    total = len(stamps) + 3  # with the 1x1 image and the two bayer ones
    check([m.frame for m in got] == sorted(set(m.frame for m in got)) and got[-1].frame == total - 1 and
          len(got) + got[-1].dropped == total,
          "~frame numbers images in the order received (the last is %d); messages + dropped = %d images received" %
          (got[-1].frame, total))
    check("a 1x1 frame is too small to extract words from" in log,
          "an image too small is logged and skipped; the model is sized by the next (%dx%d cells)" % (m0.cells_x, m0.cells_y))

    # ~resume: the model as it was saved (the node was paused: no frame since get_topic_model).
    sized = ["_frame_width:=%d" % W, "_frame_height:=%d" % H]
    node2 = start([os.path.join(build, "rost_node"), "__name:=rost2", "_resume:=" + ckpt] + sized, "rost_node2.log")
    rospy.wait_for_service("/rost2/get_topic_model", timeout=30)
    again = rospy.ServiceProxy("/rost2/get_topic_model", GetTopicModel)()
    check(list(again.counts) == list(model.counts), "~resume: the topic model the checkpoint holds")
    stop(node2)
    clash = subprocess.run([os.path.join(build, "rost_node"), "__name:=rost3", "_resume:=" + ckpt, "_K:=8"] + sized,
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=os.environ, timeout=60)
    out = clash.stdout.decode(errors="replace")
    check(clash.returncode == 2 and "~K = 8 differs from" in out and "K = 16" in out and "listening" not in out,
          "~resume with another ~K: exit %d, %s" % (clash.returncode, out.strip().splitlines()[-1] if out else ""))

    # A bag played 100x faster than it was recorded (1 ms apart: faster than
    # words are made), into a queue of two images:
    # images are dropped, counted, and the newest is always modelled; each
    # message has its own image's frame_id, whole, even where stamps repeat.
    import rosbag
    from sensor_msgs.msg import Image
    fast, ids, fast_stamps = os.path.join(work, "fast.bag"), [], []
    with rosbag.Bag(bag) as src, rosbag.Bag(fast, "w") as dst:
        images = [m for _, m, _ in src.read_messages(topics=["/camera/image_raw"]) if m.encoding == "bgr8" and m.width > 1]
        for i in range(60):
            m = images[i % len(images)]
            m.header.stamp = rospy.Time(STAMP0 + i // 2, 0)  # two images a stamp
            m.header.frame_id = "vehicle_%02d_" % i + "camera_optical_frame/" * 5
            ids.append(m.header.frame_id)
            fast_stamps.append(m.header.stamp.to_nsec())
            dst.write("/fast/image", m, rospy.Time(STAMP0, i * 100000000))  # recorded at 10 Hz
    fast_got = []
    fast_sub = rospy.Subscriber("/rost_fast/frame", FrameTopics, lambda m: fast_got.append(m), queue_size=1000)
    fast_node = start([os.path.join(build, "rost_node"), "__name:=rost_fast", "image:=/fast/image", "_image_queue:=2",
                       "_queue_slots:=1", "_budget_refines:=200"], "rost_fast.log")
    wait_until(lambda: fast_sub.get_num_connections() > 0 or fast_node.poll() is not None, 60)
    player = start(["rosbag", "play", "--wait-for-subscribers", "--keep-alive", "-q", "-r", "100", fast],
                   "rosbag_fast.log")
    quiet_since, seen = time.time(), -1
    while time.time() < quiet_since + (10 if fast_got else 60) and (not fast_got or fast_got[-1].frame != 59):
        if len(fast_got) != seen:
            quiet_since, seen = time.time(), len(fast_got)
        time.sleep(0.1)
    stop(player)
    stop(fast_node)
    last = fast_got[-1] if fast_got else None
    check(last is not None and last.frame == 59 and len(fast_got) + last.dropped == 60 and last.dropped > 0,
          "played 100x: %d messages, the last frame %s, dropped %s: the newest is modelled, every image counted" %
          (len(fast_got), last.frame if last else "-", last.dropped if last else "-"))
    check(all(m.header.frame_id == ids[m.frame] and m.header.stamp.to_nsec() == fast_stamps[m.frame]
              for m in fast_got),
          "each message has its image's frame_id (%d characters, whole) and stamp, where two share a stamp" % len(ids[0]))

    short = os.path.join(work, "short.ckpt")  # a truncated checkpoint: refused at start-up, named
    with open(ckpt, "rb") as f, open(short, "wb") as g:
        g.write(f.read()[:4096])
    trunc = subprocess.run([os.path.join(build, "rost_node"), "__name:=rost4", "_resume:=" + short],
                           stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=os.environ, timeout=60)
    out = trunc.stdout.decode(errors="replace")
    check(trunc.returncode == 2 and "~resume: " + short in out and "listening" not in out,
          "~resume of a truncated checkpoint: exit %d at start-up, naming it" % trunc.returncode)
    # ~checkpoint naming the node's own input (its vocabulary) would replace it: refused at start-up.
    over = subprocess.run([os.path.join(build, "rost_node"), "__name:=rost5", "_vocabulary:=" + short,
                           "_checkpoint:=" + short], stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                          env=os.environ, timeout=60)
    out = over.stdout.decode(errors="replace")
    check(over.returncode == 2 and "~checkpoint: " + short + " is an input of this run" in out and
          os.path.getsize(short) == 4096,
          "~checkpoint over ~vocabulary: exit %d at start-up, naming it, the file kept" % over.returncode)

    listed = subprocess.run([os.path.join(build, "rost_node"), "--params"], stdout=subprocess.PIPE,
                            check=True).stdout.decode()
    conf = subprocess.run([os.path.join(build, "rost"), "config"], stdout=subprocess.PIPE, check=True).stdout.decode()
    keys = [line.lstrip("# ").split(" = ")[0] for line in conf.splitlines() if " = " in line]
    params = [line.split()[0] for line in listed.splitlines() if line.startswith("~")]
    check(len(keys) > 30 and all("~" + k.replace(".", "_").replace("-", "_") in params for k in keys),
          "rost_node --params: a parameter for each of the %d settings of `rost config`" % len(keys))

    badnode = subprocess.run([os.path.join(build, "rost_node"), "__name:=rost_bad", "_cell_space:=0"],
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=os.environ, timeout=30)
    out = badnode.stdout.decode(errors="replace")
    check(badnode.returncode != 0 and "~cell_space = 0, allowed [1, 65536]" in out, "a bad parameter: exit %d, %s" %
          (badnode.returncode, out.strip().splitlines()[-1] if out.strip() else "(nothing)"))

    def start_up(name, params, timeout=60):
        """rost_node with these parameters on a topic no one publishes: its
        exit code (None: still running after `timeout` s, then stopped) and log."""
        p = subprocess.Popen([os.path.join(build, "rost_node"), "__name:=" + name, "image:=/nobody"] + params,
                             stdout=subprocess.PIPE, stderr=subprocess.STDOUT, env=os.environ)
        try:
            out, _ = p.communicate(timeout=timeout)
            return p.returncode, out.decode(errors="replace")
        except subprocess.TimeoutExpired:
            os.kill(p.pid, signal.SIGINT)
            out, _ = p.communicate(timeout=10)
            return None, out.decode(errors="replace")

    # The settings' one check, spelled as the node spells parameters.
    code, out = start_up("rost_eta", ["_eta:=2.0"])
    check(code == 2 and "~eta = 2, allowed [0, 1]" in out and "strategy.eta" not in out,
          "~eta out of range: exit %s, named ~eta" % code)
    code, out = start_up("rost_budgets", ["_budget_refines:=4", "_budget_ms:=5.0"])
    check(code == 2 and "~budget_ms" in out and "~budget_refines" in out and "listening" not in out,
          "two budgets: exit %s at start-up, before subscribing" % code)
    code, out = start_up("rost_unknown", ["_etta:=0.5", "_num_threads:=4"], timeout=15)
    check(code is None and "~etta is not a parameter of rost_node; ignored (did you mean ~eta?)" in out and
          "~num_threads is not a parameter" in out,
          "unknown private parameters: a warning each at start-up, with the likeliest meant")


main(run, procs)
