#!/usr/bin/python3
"""Several vehicles on one private ROS master: two rost_nodes (/auv1/rost,
/auv2/rost) on two bags of different synthetic images, each publishing its
topic model on ~topic_model, and rost_merge_node merging them.

Checks: each node's model (K, V, K x V counts, n_k the rows' sums) reaches
the counts ~get_topic_model gives once its bag is done; the merge node's
global model is the inputs' counts summed through its lifting (every word
counted once), the lifting has one entry per topic of each vehicle (-1
exactly for the empty ones); /auv2/rost (~use_global_model) publishes
~global_frame in local labels until the lifting comes (said once in its
log), then in [0, G), each frame its ~frame mapped through a lifting. Then
bad parameters: exit 2, named. Prints the bytes a merge round sends against
the words it summarises (docs/ros.md).

Usage: test_fleet.py BUILD_DIR
"""
import io
import os
import sys
import time

from roshelp import Procs, check, frames_until, image_msg, main, private_master, textured, wait_until

W, H, N, K = 256, 192, 10, 4
build = sys.argv[1]
work = os.path.join(build, "ros-test-fleet")
os.makedirs(work, exist_ok=True)
procs = Procs(work)
VEHICLES = ("auv1", "auv2")


def write_bag(path, topic, seed):
    import rosbag
    with rosbag.Bag(path, "w") as bag:
        for i in range(N):
            m = image_msg(textured(W, H, seed + i), 10**18 + i * 10**8)
            bag.write(topic, m, m.header.stamp)
    return os.path.getsize(path)


def size(msg):
    buf = io.BytesIO()
    msg.serialize(buf)
    return len(buf.getvalue())


def rows(m):
    return [list(m.counts[k * m.V:(k + 1) * m.V]) for k in range(m.K)]


def lifted_sum(models, lifting):
    """The global counts the lifting implies: each vehicle's topic rows added into their global topic's."""
    V = max(m.V for m in models)
    out = [[0] * V for _ in range(lifting.G)]
    for m, e in zip(models, lifting.vehicles):
        for k, row in enumerate(rows(m)):
            if e.global_[k] >= 0:
                for v, c in enumerate(row):
                    out[e.global_[k]][v] += c
    return out


def mapped(cells, lifting, vehicle):
    e = [x for x in lifting.vehicles if x.vehicle == vehicle][0]
    return [c if c < 0 else e.global_[c] for c in cells]


def run():
    import rospy
    from rost_msgs.msg import FrameTopics, TopicLifting, TopicModel, VehicleLifting
    from rost_msgs.srv import GetTopicModel
    bags = {v: os.path.join(work, v + ".bag") for v in VEHICLES}
    bag_bytes = {v: write_bag(bags[v], "/%s/camera" % v, 1000 * i) for i, v in enumerate(VEHICLES)}
    private_master(procs)
    rospy.init_node("rost_fleet_test", anonymous=True, disable_signals=True)
    frames = {v: [] for v in VEHICLES}
    models = {v: [] for v in VEHICLES}
    merged, liftings, global_frames = [], [], []
    subs = []
    for v in VEHICLES:
        subs.append(rospy.Subscriber("/%s/rost/frame" % v, FrameTopics, frames[v].append, queue_size=100))
        rospy.Subscriber("/%s/rost/topic_model" % v, TopicModel, models[v].append, queue_size=10)
    rospy.Subscriber("/rost_merge/global_model", TopicModel, merged.append, queue_size=10)
    rospy.Subscriber("/rost_merge/lifting", TopicLifting, liftings.append, queue_size=10)
    subs.append(rospy.Subscriber("/auv2/rost/global_frame", FrameTopics, global_frames.append, queue_size=100))
    node_bin = os.path.join(build, "rost_node")
    nodes = {}
    for v in VEHICLES:
        extra = ["_use_global_model:=true"] if v == "auv2" else []
        nodes[v] = procs.start([node_bin, "__ns:=/" + v, "__name:=rost", "image:=/%s/camera" % v,
                                "lifting:=/rost_merge/lifting", "_K:=%d" % K, "_budget_refines:=2",
                                # every image modelled however loaded the machine: queues longer than the bag
                                "_image_queue:=64", "_queue_slots:=64", "_model_period:=0.4"] + extra, v + ".log")
    merger = procs.start([os.path.join(build, "rost_merge_node"), "__name:=rost_merge", "_period:=0.4",
                          "_models:=/auv1/rost/topic_model,/auv2/rost/topic_model"], "merge.log")
    # The first images wait until this process's subscriptions to the frames
    # are connected (after the nodes advertise them), so no ~frame goes unseen;
    # --keep-alive: a player that exits may take its last, still unsent image
    # with it under load: each is stopped once its images are in.
    wait_until(lambda: all(s.get_num_connections() > 0 for s in subs) or
               any(n.poll() is not None for n in nodes.values()), 60)
    players = [procs.start(["rosbag", "play", "--wait-for-subscribers", "--keep-alive", "-q", bags[v]],
                           v + "-play.log") for v in VEHICLES]
    for v in VEHICLES:
        check(frames_until(frames[v], N, nodes[v]) == N, "%s: ~frame for each of its %d images" % (v, N))
    for p in players:
        Procs.stop(p)

    # Each node's model, once its bag is done, is the model ~get_topic_model gives.
    final = {}
    for v in VEHICLES:
        rospy.wait_for_service("/%s/rost/get_topic_model" % v, timeout=10)
        want = list(rospy.ServiceProxy("/%s/rost/get_topic_model" % v, GetTopicModel)().counts)
        got = wait_until(lambda: [m for m in models[v][-2:] if list(m.counts) == want], 15)
        check(got, "%s: ~topic_model reaches the model ~get_topic_model gives (%d words)" % (v, sum(want)))
        m = final[v] = got[-1]
        check(m.vehicle == v and m.K == K and m.V > 0 and len(m.counts) == m.K * m.V and sum(m.counts) > 0,
              "%s: vehicle '%s', K = %d, V = %d, K x V counts" % (v, m.vehicle, m.K, m.V))
        check(list(m.topic_weights) == [sum(r) for r in rows(m)], "%s: topic_weights are n_k, the rows' sums" % v)

    # The merge node: the global model is the inputs' counts summed through the lifting.
    def consistent():
        pairs = [(g, l) for g in merged[-3:] for l in liftings[-3:] if g.header.stamp == l.header.stamp]
        ins = [final[v] for v in VEHICLES]
        return [(g, l) for g, l in pairs if [e.vehicle for e in l.vehicles] == list(VEHICLES) and
                rows(g) == lifted_sum(ins, l)]
    pair = wait_until(consistent, 15)
    check(pair, "the global model is the vehicles' final counts summed through the lifting")
    g, lift = pair[-1]
    check(g.vehicle == "global" and g.K == lift.G and sum(g.counts) == sum(sum(final[v].counts) for v in VEHICLES),
          "global: G = %d topics, every word counted once (%d)" % (g.K, sum(g.counts)))
    for e in lift.vehicles:
        empty = [k for k, r in enumerate(rows(final[e.vehicle])) if sum(r) == 0]
        check(len(e.global_) == K and all(-1 <= x < lift.G for x in e.global_) and
              [k for k, x in enumerate(e.global_) if x < 0] == empty,
              "lifting of %s: one entry per topic, in [0, G), -1 for its empty topics %s" % (e.vehicle, empty))

    # ~use_global_model: local labels until the lifting comes, global ones after it.
    check(wait_until(lambda: any("auv2" in [e.vehicle for e in l.vehicles] for l in liftings), 15),
          "a lifting with auv2")
    time.sleep(0.5)
    local = {m.frame: m for m in frames["auv2"]}

    def is_local(m):
        return len(m.topic_weights) == K and list(m.cell_topics) == list(local[m.frame].cell_topics)

    def is_global(m):
        return any(m.active_topics == l.G and len(m.topic_weights) == l.G and all(-1 <= c < l.G for c in m.cell_topics)
                   and list(m.cell_topics) == mapped(local[m.frame].cell_topics, l, "auv2") for l in liftings)
    before = len(global_frames)
    n_local = next((i for i, m in enumerate(global_frames) if not is_local(m)), before)
    check(n_local >= 1 and all(is_global(m) for m in global_frames[n_local:before]),
          "~global_frame: the first %d frames in local labels (no lifting yet), the next %d mapped through a lifting"
          % (n_local, before - n_local))
    again = procs.start(["rosbag", "play", "--wait-for-subscribers", "--keep-alive", "-q", bags["auv2"]],
                        "auv2-play2.log")
    frames_until(global_frames, before + N, nodes["auv2"])
    Procs.stop(again)
    after = global_frames[before:]
    frames_until(frames["auv2"], 2 * N, nodes["auv2"])
    local.update({m.frame: m for m in frames["auv2"]})
    check(all(m.frame in local for m in after), "~frame for each of them too")
    check(len(after) == N and all(is_global(m) for m in after) and any(c >= 0 for m in after for c in m.cell_topics),
          "~global_frame after the lifting: %d frames, labels in [0, G), each frame's ~frame mapped through a lifting"
          % len(after))
    for p in list(nodes.values()) + [merger]:
        check(p.poll() is None, "every node still runs")

    # A vehicle's name on a second topic of ~models (two nodes given one ~vehicle) is refused, said in
    # the merge node's log: the lifting keeps one entry a vehicle.
    impostor = rospy.Publisher("/auv2/rost/topic_model", TopicModel, queue_size=1, latch=True)
    wait_until(lambda: impostor.get_num_connections() > 0, 15)
    impostor.publish(TopicModel(vehicle="auv1", K=final["auv1"].K, V=final["auv1"].V, counts=final["auv1"].counts,
                                topic_weights=final["auv1"].topic_weights))
    dup = "vehicle 'auv1' on /auv2/rost/topic_model came first on /auv1/rost/topic_model: ignored"
    check(wait_until(lambda: dup in procs.log("merge.log"), 15), "the merge node refused a second 'auv1'")
    time.sleep(1.0)  # a merge round or two (~period 0.4 s)
    check(all([e.vehicle for e in l.vehicles] == list(VEHICLES) for l in liftings[-2:]),
          "every lifting has one entry a vehicle: %s" % [[e.vehicle for e in l.vehicles] for l in liftings[-2:]])

    # A lifting that names global topic G (out of [0, G)) is refused, said in the log; the node runs on.
    bad_lifting = rospy.Publisher("/rost_merge/lifting", TopicLifting, queue_size=1, latch=True)
    wait_until(lambda: bad_lifting.get_num_connections() > 0, 15)
    bad_lifting.publish(TopicLifting(G=lift.G, vehicles=[VehicleLifting(vehicle="auv2", global_=[lift.G] * K)]))
    refused = "the lifting of vehicle 'auv2' has %d topics (K = %d) into G = %d: ignored" % (K, K, lift.G)
    check(wait_until(lambda: refused in procs.log("auv2.log"), 15) and nodes["auv2"].poll() is None,
          "auv2 refused a lifting naming global topic G = %d, and runs on" % lift.G)

    # The bytes a merge round sends against the words it summarises (4 bytes a word id).
    words = sum(sum(final[v].counts) for v in VEHICLES)
    sent = sum(size(final[v]) for v in VEHICLES) + size(g) + size(lift)
    print("bytes: models %s + global %d + lifting %d = %d sent for %d words (%d bytes as 4-byte word ids: %.2fx; "
          "bags %s bytes)" % ([size(final[v]) for v in VEHICLES], size(g), size(lift), sent, words, 4 * words,
                              sent / (4.0 * words), [bag_bytes[v] for v in VEHICLES]))

    Procs.stop(nodes["auv2"])
    log = procs.log("auv2.log")
    check(log.count("carries the local labels until one comes") == 1 and log.count("labels in the fleet's") == 1,
          "auv2 said once that it published local labels, and when the lifting came")

    # Bad parameters: exit 2, named.
    import subprocess
    bad = subprocess.run([node_bin, "__name:=rost_bad", "_model_period:=-1"], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, timeout=60)
    check(bad.returncode == 2 and b"~model_period" in bad.stdout, "rost_node _model_period:=-1: exit 2, named")
    bad = subprocess.run([os.path.join(build, "rost_merge_node"), "__name:=rost_merge_bad"], stdout=subprocess.PIPE,
                         stderr=subprocess.STDOUT, timeout=60)
    check(bad.returncode == 2 and b"~models" in bad.stdout, "rost_merge_node without ~models: exit 2, named")


main(run, procs)
