# Copyright 2026 The pcrp authors
#
# Licensed under the Apache License, Version 2.0 (the "License");
# you may not use this file except in compliance with the License.
# You may obtain a copy of the License at
#
#     http://www.apache.org/licenses/LICENSE-2.0
#
# Unless required by applicable law or agreed to in writing, software
# distributed under the License is distributed on an "AS IS" BASIS,
# WITHOUT WARRANTIES OR CONDITIONS OF ANY KIND, either express or implied.
# See the License for the specific language governing permissions and
# limitations under the License.

"""`make demo`: the node with the shipped model answers the shipped bag, live over DDS."""
from __future__ import annotations

from pathlib import Path
import threading
import time


DEMO_BAG = Path(__file__).resolve().parent / 'data' / 'demo_bag'


def run(model_path=None, bag=None, rate_factor=1.0) -> int:
    import rclpy
    from geometry_msgs.msg import PoseStamped
    from rclpy.parameter import Parameter
    from scipy.spatial.transform import Rotation
    from std_msgs.msg import String

    from pcrp_core import PCRP
    from pcrp_ros.bag_commands import answer_quality, format_row, header, replay, summary
    from pcrp_ros.bags import read_bag
    from pcrp_ros.node import PcrpNode
    from pcrp_ros.spinning import init_stopping_on_signals, spinning

    bag = bag or str(DEMO_BAG)
    _, truths, _ = read_bag(bag)
    sent, rows, lock = {}, [], threading.Lock()
    poses, ids = [], []
    estimates = {}   # stamp -> the node's PoseResult of that cloud, told as it is made

    def show(key, gallery_id, R, t, status):
        """Print and keep the row of the cloud stamped key, answered gallery_id at (R, t)."""
        cloud, t_sent = sent[key]
        gt = truths.get(
            (cloud['topic'], cloud['msg'].header.stamp.sec, cloud['msg'].header.stamp.nanosec), {}
        )
        row = {'topic': cloud['topic'], 'stamp': f'{key[0]}.{key[1]:09d}', 'status': status,
               'latency_ms': 1e3 * (time.monotonic() - t_sent), 'gallery_id': gallery_id,
               'category': node.model.category_of(gallery_id)}
        if key in estimates:
            row['confidence'] = estimates[key].confidence
        if gt:
            row.update(true_id=gt['gallery_id'], true_category=gt['category'],
                       **answer_quality(node.model, gallery_id, R, t, gt))
        rows.append(row)
        print(format_row(row), flush=True)

    def on_answer(topic, header, result):
        # every estimate, from the node's worker: a rejected one publishes nothing to show
        key = (header.stamp.sec, header.stamp.nanosec)
        with lock:
            estimates[key] = result
            if result.rejected and key in sent:
                show(key, result.gallery_id, result.rotation, result.translation,
                     'rejected: low_confidence')

    def pair():
        # pose and ID of one cloud are published together, one of each, in order: pair by arrival
        while poses and ids:
            msg, gid = poses.pop(0), ids.pop(0)
            key = (msg.header.stamp.sec, msg.header.stamp.nanosec)
            if key not in sent:
                continue
            q, p = msg.pose.orientation, msg.pose.position
            R = Rotation.from_quat([q.x, q.y, q.z, q.w]).as_matrix()
            show(key, gid, R, [p.x, p.y, p.z], 'ok')

    def on_pose(msg: PoseStamped):
        with lock:
            poses.append(msg)
            pair()

    def on_id(msg: String):
        with lock:
            ids.append(msg.data)
            pair()

    # Ctrl-C ends the replay early and still shows what was answered; the nodes are destroyed
    # before the context is shut down
    init_stopping_on_signals()
    node = PcrpNode(
        model=PCRP.load(model_path),
        parameter_overrides=[Parameter('sensor_at_origin', value=True)],
        on_answer=on_answer,
    )
    client = rclpy.create_node('pcrp_demo')
    client.create_subscription(String, '/segmented_object/gallery_id', on_id, 10)
    client.create_subscription(PoseStamped, '/segmented_object/pose', on_pose, 10)
    print(header(), flush=True)

    def on_publish(cloud, msg):
        with lock:
            sent[(msg.header.stamp.sec, msg.header.stamp.nanosec)] = (cloud, time.monotonic())

    def decided():
        counts = node.stats['segmented_object'].snapshot()
        return sum(counts.get(k, 0) for k in ('answered', 'rejected', 'dropped_stale'))
    try:
        # the executor's thread has stopped before the nodes are destroyed (spinning)
        with spinning(None, node, client):
            try:
                n = replay(client, bag, rate_factor, True, None, on_publish)
                end = time.monotonic() + 30.0
                while time.monotonic() < end and decided() < n:
                    time.sleep(0.1)
                time.sleep(0.5)
            except KeyboardInterrupt:
                print('\ndemo stopped by Ctrl-C', flush=True)
            snap = node.stats['segmented_object'].snapshot()
    finally:
        rclpy.try_shutdown()
    print(f"\nnode: received {snap.get('received', 0)}, answered {snap.get('answered', 0)}, "
          f"rejected {snap.get('rejected', 0)}, dropped as stale {snap.get('dropped_stale', 0)}")
    print(summary(rows))
    return 0


def register(sub) -> None:
    p = sub.add_parser('demo', help='the node answering the shipped demo bag, live over DDS')
    p.add_argument('--model', default=None, help='model directory (default: the shipped model)')
    p.add_argument('--bag', default=str(DEMO_BAG))
    p.add_argument('--rate-factor', type=float, default=1.0)
    p.set_defaults(func=lambda a: run(a.model, a.bag, a.rate_factor))
