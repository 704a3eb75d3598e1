#!/usr/bin/python3
"""`rost run FILE.bag`: images from a bag, results into a bag.

Writes a bag of real footage (diver.mov) with the same frames as raw
sensor_msgs/Image (bgr8), as CompressedImage (jpeg), and one topic whose
encoding rost cannot read; then checks: without --topic the image topics are
listed and the exit is 2 (also with -q); frames.csv has the messages' stamps;
the compressed topic gives as many frames; --out.bag holds a FrameTopics per
image, stamped like it (with --topics.grow its active_topics follow
perplexity.csv's topics); the unreadable encoding and a truncated bag give one
line naming the bag, the topic (and message) with exit 2.

Usage: test_bag.py BUILD_DIR FOOTAGE_DIR
"""
import csv
import os
import shutil
import struct
import subprocess
import sys
import tempfile
import zlib

N = 8
W, H = 320, 240
STAMP0_NS = 1700000000 * 10**9 + 5

build, footage = sys.argv[1], sys.argv[2]
diver = os.path.join(footage, "pd-extendedview/usr/share/doc/pd-extendedview/media/diver.mov")
if not os.path.exists(diver):
    if os.environ.get("CI") == "true":
        sys.exit("no footage at %s" % diver)
    print("skipped: no footage (scripts/fetch-footage.sh pd-extendedview)")
    sys.exit(77)
work = tempfile.mkdtemp(prefix="rost-bag-", dir=build)
rost = os.path.join(build, "rost")


def check(cond, what):
    if not cond:
        raise AssertionError(what)
    print("ok:", what)


def ffmpeg(args):
    return subprocess.run(["ffmpeg", "-loglevel", "error", "-i", diver, "-frames:v", str(N), "-vf",
                           "scale=%d:%d" % (W, H)] + args, check=True, stdout=subprocess.PIPE).stdout


def write_bag(path):
    import rosbag
    import rospy
    from sensor_msgs.msg import CompressedImage, Image
    raw = ffmpeg(["-f", "rawvideo", "-pix_fmt", "bgr24", "-"])
    jpegs = os.path.join(work, "jpeg")
    os.makedirs(jpegs)
    ffmpeg(["-q:v", "3", os.path.join(jpegs, "%03d.jpg")])
    stamps = []

    def tiny(w, h, ns):  # an image too small to extract words from (rost::vision's frame size rule)
        img = Image(height=h, width=w, encoding="bgr8", step=w * 3, data=bytes(w * h * 3))
        img.header.stamp = rospy.Time(ns // 10**9, ns % 10**9)
        return img
    with rosbag.Bag(path, "w") as bag:
        bag.write("/cam/small", tiny(1, 1, STAMP0_NS - 2), tiny(1, 1, STAMP0_NS - 2).header.stamp)
        bag.write("/cam/small", tiny(300, 1, STAMP0_NS - 1), tiny(300, 1, STAMP0_NS - 1).header.stamp)
        for i in range(N):
            ns = STAMP0_NS + i * 66666667
            t = rospy.Time(ns // 10**9, ns % 10**9)
            img = Image(height=H, width=W, encoding="bgr8", step=W * 3, data=raw[i * W * H * 3:(i + 1) * W * H * 3])
            img.header.stamp, img.header.frame_id = t, "cam"
            bag.write("/cam/image_raw", img, t)
            bag.write("/cam/small", img, t)
            if i == N // 2:
                bag.write("/cam/small", tiny(1, 300, ns + 1), tiny(1, 300, ns + 1).header.stamp)
            jpg = CompressedImage(format="jpeg", data=open(os.path.join(jpegs, "%03d.jpg" % (i + 1)), "rb").read())
            jpg.header.stamp, jpg.header.frame_id = t, "cam"
            bag.write("/cam/image_raw/compressed", jpg, t)
            bayer = Image(height=H, width=W, encoding="bayer_rggb8", step=W, data=bytes(W * H))
            bayer.header.stamp = t
            bag.write("/cam/bayer", bayer, t)
            stamps.append(ns)
    return stamps


def rost_run(*args):
    p = subprocess.run([rost, "run"] + list(args), stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    return p.returncode, p.stderr.decode()


def main():
    bag = os.path.join(work, "in.bag")
    stamps = write_bag(bag)

    for quiet in ([], ["-q"]):
        code, err = rost_run(bag, "--out", os.path.join(work, "none"), *quiet)
        check(code == 2 and "/cam/image_raw (sensor_msgs/Image, %d messages)" % N in err and
              "/cam/image_raw/compressed (sensor_msgs/CompressedImage, %d messages)" % N in err,
              "without --topic%s: exit 2 and the image topics listed" % (" (-q)" if quiet else ""))
    check(not os.path.exists(os.path.join(work, "none")), "no outputs without --topic")

    out, outbag = os.path.join(work, "raw"), os.path.join(work, "results.bag")
    # A file named as the bag plus ".tmp" (a checkpoint, say) is not the bag's
    # staging file: it stays, and no staging file is left.
    open(outbag + ".tmp", "wb").write(b"not the bag's")
    code, err = rost_run(bag, "--topic", "/cam/image_raw", "--out", out, "--out.bag", outbag, "-q", "--no-overlay")
    check(code == 0, "raw images: exit 0 " + err.strip())
    check(open(outbag + ".tmp", "rb").read() == b"not the bag's" and
          not [f for f in os.listdir(work) if f.startswith(".results.bag.tmp")],
          "results.bag.tmp untouched, no staging file left")
    os.remove(outbag + ".tmp")
    # --out.bag through a link: written where it leads, the link kept.
    os.makedirs(os.path.join(work, "store"))
    open(os.path.join(work, "store", "res.bag"), "wb").write(b"old")
    os.symlink(os.path.join("store", "res.bag"), os.path.join(work, "link.bag"))
    code, err = rost_run(bag, "--topic", "/cam/image_raw", "--out", os.path.join(work, "linked"), "--out.bag",
                         os.path.join(work, "link.bag"), "-q", "--no-overlay", "--no-summary")
    check(code == 0 and os.path.islink(os.path.join(work, "link.bag")) and
          open(os.path.join(work, "store", "res.bag"), "rb").read(13) == b"#ROSBAG V2.0\n",
          "--out.bag through a link: the link kept, the bag where it leads " + err.strip())
    rows = list(csv.DictReader(open(os.path.join(out, "frames.csv"))))
    check([int(r["timestamp_us"]) for r in rows] == [s // 1000 for s in stamps],
          "frames.csv has the messages' stamps")

    # Images too small to extract words from: skipped, each named, never sizing the model.
    small = os.path.join(work, "small")
    code, err = rost_run(bag, "--topic", "/cam/small", "--out", small, "-q", "--no-overlay")
    rows = list(csv.DictReader(open(os.path.join(small, "frames.csv")))) if code == 0 else []
    check(code == 0 and [int(r["timestamp_us"]) for r in rows] == [s // 1000 for s in stamps] and
          "topic /cam/small, message 0: a 1x1 frame is too small to extract words from" in err and
          "topic /cam/small, message 1: a 300x1 frame is too small" in err and
          "topic /cam/small, message %d: a 1x300 frame is too small" % (2 + N // 2 + 1) in err and
          "%dx%d" % (W, H) in open(os.path.join(small, "run.txt")).read(),
          "images too small: skipped and named, the model sized by the first usable one: " + err.strip())

    import rosbag
    with rosbag.Bag(outbag) as b:
        msgs = [(topic, m) for topic, m, _ in b.read_messages()]
    check([t for t, _ in msgs] == ["/rost/frame"] * N, "--out.bag: a FrameTopics on /rost/frame per image")
    check([m.header.stamp.to_nsec() for _, m in msgs] == stamps and all(m.header.frame_id == "cam" for _, m in msgs),
          "--out.bag: stamped like the images, with their frame_id")
    m = msgs[0][1]
    check(m.cells_x == (W + 63) // 64 and m.cells_y == (H + 63) // 64 and len(m.cell_topics) == m.cells_x * m.cells_y
          and abs(sum(m.topic_weights) - 1) < 1e-3, "--out.bag: cells and topic weights")
    sur = [float(r["surprise"]) for r in csv.DictReader(open(os.path.join(out, "surprise.csv")))]
    check(all(abs(a - mm.surprise) <= 1e-3 * abs(a) for a, (_, mm) in zip(sur, msgs)),
          "--out.bag: the surprise of surprise.csv")

    # Topics that grow: active_topics is the perplexity.csv `topics` of the
    # frame, and the labels from there on weigh nothing.
    gout, gbag = os.path.join(work, "grow"), os.path.join(work, "grow.bag")
    code, err = rost_run(bag, "--topic", "/cam/image_raw", "--out", gout, "--out.bag", gbag, "-q", "--no-overlay",
                         "-K", "32", "--topics.grow", "--gamma", "0.3")
    check(code == 0, "growth: exit 0 " + err.strip())
    with rosbag.Bag(gbag) as b:
        grown = [m for _, m, _ in b.read_messages()]
    topics = [int(r["topics"]) for r in csv.DictReader(open(os.path.join(gout, "perplexity.csv")))]
    # (Topics open by split moves about once a sweep's worth of tokens, so
    # eight frames may keep one: the count is checked, not its growth.)
    check(len(grown) == N and [m.active_topics for m in grown] == topics and 0 < topics[-1] < 32,
          "growth: active_topics per frame as perplexity.csv's topics %s" % topics)
    check(all(len(m.topic_weights) == 32 and not any(m.topic_weights[m.active_topics:]) for m in grown),
          "growth: no weight beyond the open topics")

    code, err = rost_run(bag, "--topic", "/cam/image_raw/compressed", "--out", os.path.join(work, "jpeg"), "-q",
                         "--no-overlay", "--no-summary")
    rows = list(csv.DictReader(open(os.path.join(work, "jpeg", "frames.csv")))) if code == 0 else []
    check(code == 0 and len(rows) == N, "compressed images: %d frames" % len(rows))

    code, err = rost_run(bag, "--topic", "/cam/bayer", "--out", os.path.join(work, "bayer"), "-q")
    check(code == 2 and len(err.strip().splitlines()) == 1 and "topic /cam/bayer, message 0" in err and
          "bayer_rggb8" in err, "an encoding rost cannot read: exit 2, " + err.strip())

    # A topic the bag lacks names those it has; a file that is no bag says so
    # (not "truncated?", as rosbag's own "Error reading version line" was read).
    code, err = rost_run(bag, "--topic", "/nope", "--out", os.path.join(work, "nope"), "-q")
    # The topics are listed as without --topic: one indented line each.
    lines = err.strip().splitlines()
    check(code == 2 and lines[0].endswith("no topic /nope in the bag; its image topics:")
          and "  /cam/image_raw (sensor_msgs/Image, %d messages)" % N in lines[1:]
          and all(l.startswith("  /") for l in lines[1:]), "a topic the bag lacks: exit 2, " + err.strip())
    notbag = os.path.join(work, "log.bag")
    open(notbag, "w").write("garbage\n")
    code, err = rost_run(notbag, "--out", os.path.join(work, "notbag"), "-q")
    check(code == 2 and err.strip() == "rost: error: %s: not a ROS bag (a bag begins with '#ROSBAG V2.0')" % notbag,
          "a file that is no bag: exit 2, " + err.strip())

    trunc = os.path.join(work, "truncated.bag")
    data = open(bag, "rb").read()
    open(trunc, "wb").write(data[:len(data) * 2 // 3])
    code, err = rost_run(trunc, "--topic", "/cam/image_raw", "--out", os.path.join(work, "trunc"), "-q")
    check(code == 2 and len(err.strip().splitlines()) == 1 and "topic /cam/image_raw" in err,
          "a truncated bag: exit 2, " + err.strip())

    # Messages that do not deserialise or decode, first or later: one line
    # naming the message, exit 2, nothing left in the output directory (they
    # had aborted with exit 134 and left its staging directory).
    import rosbag
    import rospy
    from sensor_msgs.msg import CompressedImage, Image
    good = open(os.path.join(work, "jpeg", "001.jpg"), "rb").read()

    def chunk(tag, data):
        return struct.pack(">I", len(data)) + tag + data + struct.pack(">I", zlib.crc32(tag + data) & 0xffffffff)
    huge_png = (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", 200000, 200000, 8, 2, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(b"\x00" * 100)) + chunk(b"IEND", b""))
    for name, at in (("short message first", 0), ("short message later", 2), ("huge png first", 0),
                     ("huge png later", 2)):
        path = os.path.join(work, "bad.bag")
        with rosbag.Bag(path, "w") as b:
            for i in range(4):
                t = rospy.Time(1700000000 + i, 0)
                if i == at and name.startswith("short"):
                    b.write("/cam/c", ("sensor_msgs/CompressedImage", b"\x01\x00\x00\x00\x02",
                                       CompressedImage._md5sum, CompressedImage), t, raw=True)
                else:
                    m = CompressedImage(format="png" if i == at else "jpeg", data=huge_png if i == at else good)
                    m.header.stamp = t
                    b.write("/cam/c", m, t)
        out = os.path.join(work, "bad")
        shutil.rmtree(out, ignore_errors=True)
        os.makedirs(out)
        code, err = rost_run(path, "--topic", "/cam/c", "--out", out, "-q", "--no-overlay")
        check(code == 2 and len(err.strip().splitlines()) == 1 and "topic /cam/c, message %d" % at in err and
              ("cannot read the message: Buffer Overrun" in err if name.startswith("short") else
               "that OpenCV refuses to decode" in err) and
              not [f for f in os.listdir(out) if f.startswith(".rost-partial")],
              "%s: exit %d, %s" % (name, code, err.strip()))


try:
    main()
    print("1 passed, 0 failed")
finally:
    shutil.rmtree(work, ignore_errors=True)
