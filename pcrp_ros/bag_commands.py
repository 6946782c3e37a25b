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

"""`pcrp make-bag | process | replay`: the rosbag side of the command line."""
from __future__ import annotations

import json
from pathlib import Path
import sys
import time

import numpy as np

START_NS = 1_700_000_000 * 10**9   # bags start at a fixed time so they are reproducible
# a level camera's optical frame (x right, y down, z forward) looking at a z-up object standing
# upright
LEVEL_CAMERA = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
UP_IN_LEVEL_CAMERA = [0.0, -1.0, 0.0]


def answer_quality(model, gallery_id: str, R, t, truth: dict) -> dict:
    """
    Return how right an answer is against a bag's ground truth.

    The rotation error (degrees; blind to symmetry) and the surface error as ADD-S counts it (the
    true object's points where the truth puts them, to the nearest of the answer's object's points
    where the answer puts them), over the true object's size: a can turned about its axis is right
    by the second, not the first.
    """
    from scipy.spatial import cKDTree

    from pcrp_core.geometry import rotation_angle_deg

    true_points = model.gallery_cloud(truth['gallery_id']).astype(np.float64)
    shown = true_points @ np.asarray(truth['rotation']).T + np.asarray(truth['translation'])
    answer_points = model.gallery_cloud(gallery_id).astype(np.float64)
    posed = answer_points @ np.asarray(R).T + np.asarray(t)
    size = 2.0 * float(np.linalg.norm(true_points - true_points.mean(0), axis=1).max())
    surface = float(cKDTree(posed).query(shown)[0].mean())
    return {'rot_err': rotation_angle_deg(R, truth['rotation']), 'surface_err': surface / size}


# -- make-bag -------------------------------------------------------------------------------------
def _camera_view(mesh, index: int, k: int, seed: int, stand, rng):
    """
    Return (points, R, t) of a mesh (metres) as a depth camera measures it.

    Anywhere in front of it turned every way (the evaluation's free scenes), or, given stand (the
    rotation taking the mesh's up axis to z), standing upright before a level camera.
    """
    from scipy.spatial.transform import Rotation
    from pcrp_core.evaluation.scenes import sample_scene
    from pcrp_core.sources.camera import RangeNoise, view_of

    if stand is None:
        scene = sample_scene(mesh, str(index), index, k, 'free', seed=seed)
        return scene.points.astype(np.float64), scene.R, scene.t
    R = LEVEL_CAMERA @ Rotation.from_euler('z', rng.uniform(0.0, 2 * np.pi)).as_matrix() @ stand
    centre = (mesh.vertices.min(0) + mesh.vertices.max(0)) / 2
    t = np.array([rng.uniform(-0.1, 0.1), rng.uniform(-0.05, 0.05),
                  rng.uniform(0.5, 0.8)]) - R @ centre
    return view_of(mesh, R, t, noise=RangeNoise(), rng=rng), R, t


def make_bag(
    out,
    source='household',
    split='train',
    count=30,
    rate=5.0,
    topic='segmented_object',
    seed=0,
    partial=True,
    noise=0.003,
    frame='camera_optical_frame',
    storage='sqlite3',
    upright: bool = False,
    up_axis: str | None = None,
) -> int:
    """
    Write a bag of object clouds with their ground truth.

    upright: objects stand upright, turned about the vertical only, before a level camera
    (up is UP_IN_LEVEL_CAMERA in its frame); otherwise they are turned every way. up_axis: the
    objects' up axis in their own frame ('z', '-y', ...; default: what the source says, which a
    folder of meshes does not). Objects with meshes (household, folders of meshes) are seen as a
    depth camera measures them (ray cast, range noise in metres); others by hidden point removal
    with noise in object radii.
    """
    from scipy.spatial.transform import Rotation
    from pcrp_core.geometry import rotation_taking, unit_axis
    from pcrp_core.sources import load_source
    from pcrp_core.sources.views import random_rotation, sensor_view
    from pcrp_ros.bags import BagWriter, cloud_msg, header, T

    objects = load_source(source, split=split)
    ups = {up_axis or o.up for o in objects}
    if upright and (None in ups or len(ups) > 1):
        raise ValueError(f'{source}: --upright needs to know which way is up: give --up-axis, '
                         'as to pcrp build')
    stand = rotation_taking(unit_axis(ups.pop()), [0.0, 0.0, 1.0]) if upright else None
    rng = np.random.default_rng(seed)
    order = rng.permutation(len(objects))
    with BagWriter(out, storage) as bag:
        for k in range(count):
            index = int(order[k % len(objects)])
            obj = objects[index]
            if obj.mesh is not None and partial:
                pts, R, t = _camera_view(obj.mesh, index, k, seed, stand, rng)
            else:
                if upright:
                    yaw = Rotation.from_euler('z', rng.uniform(0.0, 2 * np.pi)).as_matrix()
                    R = LEVEL_CAMERA @ yaw @ stand
                else:
                    R = random_rotation(rng)
                # in front of the camera (optical frame: z forward), about three object radii away
                radius = float(np.linalg.norm(obj.points - obj.points.mean(0), axis=1).max())
                offset = [rng.uniform(-0.3, 0.3), rng.uniform(-0.3, 0.3), rng.uniform(2.5, 3.5)]
                t = np.array(offset) * radius
                pts = obj.points.astype(np.float64) @ R.T + t
                if partial:
                    pts = sensor_view(pts, np.zeros(3), rng, noise * radius)
            ts = START_NS + int(k * 1e9 / rate)
            sec, nsec = divmod(ts, 10**9)
            bag.write(topic, cloud_msg(pts, header(sec, nsec, frame)), ts)
            gt = {'stamp': [sec, nsec], 'gallery_id': obj.gallery_id, 'category': obj.category,
                  'rotation': np.asarray(R).tolist(), 'translation': np.asarray(t).tolist()}
            bag.write(f'{topic}/ground_truth', T['std_msgs/msg/String'](data=json.dumps(gt)), ts)
    return count


def register_make_bag(sub) -> None:
    p = sub.add_parser(
        'make-bag', help='write a rosbag2 of segmented-object clouds with ground truth'
    )
    p.add_argument('--out', required=True, help='bag directory to create')
    p.add_argument(
        '--source',
        default='household',
        help='household[:N], procedural[:N], a folder of meshes or a ModelNet40 archive '
        '(default household: the shipped gallery)',
    )
    p.add_argument('--split', default='train', choices=['train', 'test'],
                   help="train: the gallery's own objects (IDs checkable); test: unseen objects")
    p.add_argument('--count', type=int, default=30)
    p.add_argument('--rate', type=float, default=5.0, help='clouds per second')
    p.add_argument('--topic', default='segmented_object')
    p.add_argument('--frame', default='camera_optical_frame')
    p.add_argument('--seed', type=int, default=0)
    p.add_argument(
        '--full',
        action='store_true',
        help='complete objects instead of one-sided depth-camera views',
    )
    p.add_argument(
        '--noise', type=float, default=0.003, help='range noise, in object radii (default 0.003)'
    )
    p.add_argument('--storage', default='sqlite3', choices=['sqlite3', 'mcap'])
    p.add_argument(
        '--upright',
        action='store_true',
        help='objects standing upright, turned about the vertical only, before a level camera '
        "(then up is 0,-1,0 in the clouds' frame: the node's up_vector, process --up=0,-1,0)",
    )
    p.add_argument(
        '--up-axis', choices=['x', 'y', 'z', '-x', '-y', '-z'], default=None,
        help="with --upright, the objects' up axis in their own frame, as pcrp build takes it "
        '(default: what the source says: z for the shipped gallery, ModelNet40 and the generator)',
    )
    p.set_defaults(func=_make_bag)


def _make_bag(a) -> int:
    if Path(a.out).exists():
        print(f'pcrp: error: {a.out} exists already; give another --out, or remove it first',
              file=sys.stderr)
        return 2
    try:
        n = make_bag(
            a.out,
            a.source,
            a.split,
            a.count,
            a.rate,
            a.topic,
            a.seed,
            not a.full,
            a.noise,
            a.frame,
            a.storage,
            a.upright,
            a.up_axis,
        )
    except ValueError as e:
        print(f'pcrp: error: {e}', file=sys.stderr)
        return 2
    print(f'wrote {n} clouds to {a.out}')
    return 0


# -- process --------------------------------------------------------------------------------------
def bag_scenes(bag, topic: str, clouds: list, model, viewpoint,
               problems: list) -> tuple[dict, dict]:
    """
    Return ({cloud index: the part of its scene in reach}, {cloud index: rejected_<reason>}).

    As the node's scene_topics match: the scene of a cloud is the message on topic with its stamp
    and frame (pcrp_ros/scenes.py), a depth cloud or a depth image read with the CameraInfo
    recorded beside it. They are read one at a time, and only what is in reach of a cloud is
    kept: None for a cloud the model would use no scene for (not answered view by view). A scene
    that cannot be used is counted by its reason, as the node counts it.
    """
    from pcrp_ros.bags import scene_messages
    from pcrp_ros.scenes import read_frame, unusable

    waiting = {}
    for k, c in enumerate(clouds):
        if c['error'] is None:
            h = c['msg'].header
            waiting.setdefault((h.stamp.sec, h.stamp.nanosec, h.frame_id), []).append(k)
    found, rejected = {}, {}
    for msg, camera_info in scene_messages(bag, topic, problems):
        h = msg.header
        key = (h.stamp.sec, h.stamp.nanosec, h.frame_id)
        if key not in waiting:
            continue
        clouds_of_frame = waiting.pop(key)
        try:
            scene = read_frame(msg, h.frame_id, camera_info)
            for k in clouds_of_frame:
                found[k] = model.scene_in_reach(clouds[k]['points'], scene, viewpoint)
        except Exception as e:  # as in the node: the clouds are answered without it
            outcome, why = unusable(e)
            rejected.update({k: outcome for k in clouds_of_frame if k not in found})
            problems.append(f'{topic} @ {h.stamp.sec}.{h.stamp.nanosec:09d}: scene not used: '
                            f'{why}')
    return found, rejected


def process_bag(bag, out, model, sensor_at_origin=True, quiet=False, topics=None, up=None,
                scene_topic=None):
    """
    Run the core over every cloud of a bag (or of the given topics).

    Writes the node's outputs into `out` and returns rows. Unreadable clouds become rows with
    their reason, never a stop. up: which way is up in the clouds' frame, as the node's
    up_vector (None: unknown). scene_topic: the camera's depth clouds or depth images, each cloud
    answered with the one of its stamp and frame (the node's scene_topics); rows then say whether
    one was (scene: used, missing, unused or rejected_<reason>, as the node counts them).
    """
    from pcrp_core import InvalidCloud
    from pcrp_ros.bags import BagWriter, cloud_msg, pose_msg, read_bag, T
    from pcrp_ros.conversions import aligned_points
    from pcrp_ros.depth_images import camera_info_topic

    viewpoint = np.zeros(3) if sensor_at_origin else None
    leave = (scene_topic, camera_info_topic(scene_topic)) if scene_topic else ()
    clouds, truths, problems = read_bag(bag, topics, leave=leave)
    scenes, unusable = (bag_scenes(bag, scene_topic, clouds, model, viewpoint, problems)
                        if scene_topic else ({}, {}))
    for p in problems:
        print(f'pcrp: {bag}: {p}', file=sys.stderr)
    rows = []
    if not clouds:   # no bag of outputs for nothing: it would only be in the way of the next run
        return rows
    with BagWriter(out) as writer:
        for k, c in enumerate(clouds):
            hdr = c['msg'].header
            row = {'topic': c['topic'], 'stamp': f'{hdr.stamp.sec}.{hdr.stamp.nanosec:09d}'}
            if scene_topic:
                row['scene'] = unusable.get(k) or ('missing' if k not in scenes else
                                                   'unused' if scenes[k] is None else 'used')
            gt = truths.get((c['topic'], hdr.stamp.sec, hdr.stamp.nanosec))
            if c['error'] is not None:
                row.update(status=f"rejected: {c['error'].reason}")
            else:
                try:
                    t0 = time.perf_counter()
                    r = model.estimate(c['points'], viewpoint=viewpoint, up=up,
                                       scene=scenes.get(k))
                    row['latency_ms'] = 1e3 * (time.perf_counter() - t0)
                except InvalidCloud as e:
                    r, row['status'] = None, f'rejected: {e.reason}'
                except Exception as e:  # as in the node: one cloud must not end the run
                    r, row['status'] = None, 'rejected: internal_error'
                    print(
                        f"pcrp: {bag}: {c['topic']} @ {row['stamp']}: {type(e).__name__}: {e}",
                        file=sys.stderr,
                    )
                if r is not None:
                    row.update(
                        status='rejected: low_confidence' if r.rejected else 'ok',
                        gallery_id=r.gallery_id,
                        category=r.category,
                        score=r.score,
                        confidence=r.confidence,
                    )
                    if not r.rejected:
                        writer.write(f"{c['topic']}/pose", pose_msg(r, hdr), c['timestamp'])
                        writer.write(
                            f"{c['topic']}/gallery_id",
                            T['std_msgs/msg/String'](data=r.gallery_id),
                            c['timestamp'],
                        )
                        writer.write(
                            f"{c['topic']}/aligned_model",
                            cloud_msg(aligned_points(r, model.gallery_cloud(r.gallery_id)), hdr),
                            c['timestamp'],
                        )
                    if gt and gt['gallery_id'] in model.gallery.index:
                        row.update(answer_quality(model, r.gallery_id, r.rotation, r.translation,
                                                  gt))
            if gt:
                row.update(true_id=gt['gallery_id'], true_category=gt['category'])
            rows.append(row)
            if not quiet:
                print(format_row(row, id_width(model)), flush=True)
    return rows


def id_width(model) -> int:
    """Return the columns a row gives gallery IDs: the model's longest, at least 14."""
    return max(14, *(len(g) for g in model.gallery_ids))


def format_row(row, width: int = 14) -> str:
    """One cloud's row under header(width); width: columns for each gallery ID."""
    err = f"{row['rot_err']:7.1f}" if 'rot_err' in row else '      -'
    surface = f"{100 * row['surface_err']:6.1f}%" if 'surface_err' in row else '      -'
    conf = f"{row['confidence']:5.2f}" if 'confidence' in row else '    -'
    lat = f"{row['latency_ms']:7.0f}" if 'latency_ms' in row else '      -'
    return (f"{row['topic'][:18]:18s} {row['stamp']:>21s} "
            f"{row.get('true_id', '-')[:width]:{width}s} "
            f"{row.get('gallery_id', '-')[:width]:{width}s} {err} {surface} {conf} {lat}  "
            f"{row.get('status', '')}")


def header(width: int = 14) -> str:
    """Return the line over format_row's rows."""
    return (f"{'topic':18s} {'stamp':>21s} {'true id':{width}s} {'answer':{width}s} "
            f"{'rot err':>7s} {'ADD-S':>7s} {'conf':>5s} {'lat ms':>7s}  status")


def summary(rows) -> str:
    n = len(rows)
    ok = [r for r in rows if r.get('status') == 'ok']
    lines = [f'clouds {n}, answered {len(ok)}, rejected {n - len(ok)}']
    reasons = {}
    for r in rows:
        if r.get('status', '').startswith('rejected'):
            reasons[r['status']] = reasons.get(r['status'], 0) + 1
    lines += [f'  {k}: {v}' for k, v in sorted(reasons.items())]
    scenes = [r['scene'] for r in rows if 'scene' in r]
    if scenes:
        kinds = ['used', 'missing', 'unused'] + sorted(set(scenes) - {'used', 'missing', 'unused'})
        lines.append('scenes: ' + ', '.join(f'{k} {scenes.count(k)}' for k in kinds
                                            if k in scenes))
    lat = [r['latency_ms'] for r in rows if 'latency_ms' in r]
    if lat:
        lines.append(f'latency ms: median {np.median(lat):.0f}, '
                     f'95th percentile {np.percentile(lat, 95):.0f}')
    withgt = [r for r in ok if 'true_id' in r and 'rot_err' in r]
    if withgt:
        err = np.array([r['rot_err'] for r in withgt])
        surface = np.array([r['surface_err'] for r in withgt])
        category = np.mean([r['category'] == r['true_category'] for r in withgt])
        gallery_id = np.mean([r['gallery_id'] == r['true_id'] for r in withgt])
        lines.append(
            f'accuracy on answered clouds ({len(withgt)}): right object {gallery_id:.0%}, '
            f'category {category:.0%}, pose right (ADD-S under 10 % of the size) '
            f'{np.mean(surface < 0.1):.0%}, ADD-S median {np.median(surface):.1%} of the size; '
            f'rotation error median {np.median(err):.1f} deg (blind to symmetry: a can turned '
            'about its axis is wrong by it, right by ADD-S)')
    return '\n'.join(lines)


def register_process(sub) -> None:
    p = sub.add_parser(
        'process', help="run PCRP over a bag offline and write the node's outputs to a new bag"
    )
    p.add_argument('bag')
    p.add_argument('--out', required=True, help='results bag directory to create')
    p.add_argument('--model', default=None, help='model directory (default: the shipped model)')
    p.add_argument('--complete-objects', action='store_true',
                   help="clouds are complete objects, not one sensor's view from the frame origin")
    p.add_argument(
        '--topics',
        nargs='*',
        default=None,
        help='cloud topics to answer (default: every PointCloud2 topic)',
    )
    p.add_argument('--up', default=None, metavar='X,Y,Z',
                   help="which way is up in the clouds' frame, as the node's up_vector")
    p.add_argument('--scene-topic', default=None, metavar='TOPIC',
                   help="the camera's whole depth clouds, or depth images (with the CameraInfo "
                   'on camera_info beside them): each cloud is answered with the one of its '
                   "stamp and frame, as the node's scene_topics")
    p.set_defaults(func=_process)


def _process(args) -> int:
    from pcrp_core import ModelError, PCRP

    from pcrp_core.cli import parse_up

    # checked before the model loads, and before anything is written
    if not Path(args.bag).exists():
        print(f'pcrp: error: {args.bag}: no such bag', file=sys.stderr)
        return 2
    if Path(args.out).exists():
        print(f'pcrp: error: {args.out} exists already; give another --out, or remove it first',
              file=sys.stderr)
        return 2
    try:
        model = PCRP.load(args.model)
        up = parse_up(args.up)
        if up is not None:
            model.check_up(
                up
            )  # a model without an up axis, or a zero vector: say so before any cloud
    except (ModelError, ValueError) as e:
        print(f'pcrp: error: {e}', file=sys.stderr)
        return 2
    print(header(id_width(model)))
    rows = process_bag(
        args.bag,
        args.out,
        model,
        sensor_at_origin=not args.complete_objects,
        topics=args.topics,
        up=up,
        scene_topic=args.scene_topic,
    )
    print(summary(rows))
    return 0 if rows else 1  # a partial read is reported above; nothing read at all is a failure


# -- replay and demo ------------------------------------------------------------------------------
def replay(node, bag, rate_factor=1.0, restamp=True, topics=None, on_publish=None,
           on_start=None):
    """
    Publish a bag's clouds from `node` at the recorded rate (times rate_factor).

    With restamp, each header gets the current time (so ages and latencies are live);
    on_start(n) is told how many clouds are about to go out, on_publish(cloud, msg) each cloud
    sent. Returns the number of clouds published.
    """
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import PointCloud2, PointField
    from std_msgs.msg import Header
    from pcrp_ros.bags import read_bag

    clouds, _, problems = read_bag(bag, topics)
    for p in problems:
        print(f'pcrp: {bag}: {p}', file=sys.stderr)
    # reliable publishers match best-effort and reliable subscribers alike
    pubs = {
        t: node.create_publisher(PointCloud2, t, QoSProfile(depth=10))
        for t in {c['topic'] for c in clouds}
    }
    deadline = time.monotonic() + 5.0
    while time.monotonic() < deadline and not all(
        p.get_subscription_count() for p in pubs.values()
    ):
        time.sleep(0.05)
    if on_start:
        on_start(len(clouds))
    t0_bag, t0 = (clouds[0]['timestamp'] if clouds else 0), time.monotonic()
    for c in clouds:
        delay = (c['timestamp'] - t0_bag) * 1e-9 / rate_factor - (time.monotonic() - t0)
        if delay > 0:
            time.sleep(delay)
        src = c['msg']
        msg = PointCloud2(
            height=src.height,
            width=src.width,
            is_bigendian=src.is_bigendian,
            point_step=src.point_step,
            row_step=src.row_step,
            is_dense=src.is_dense,
            fields=[
                PointField(name=f.name, offset=f.offset, datatype=f.datatype, count=f.count)
                for f in src.fields
            ],
            data=bytes(src.data),
        )
        msg.header = Header(frame_id=src.header.frame_id)
        if restamp:
            msg.header.stamp = node.get_clock().now().to_msg()
        else:
            msg.header.stamp.sec, msg.header.stamp.nanosec = (
                src.header.stamp.sec,
                src.header.stamp.nanosec,
            )
        if on_publish:
            on_publish(c, msg)
        pubs[c['topic']].publish(msg)
    return len(clouds)


def register_replay(sub) -> None:
    p = sub.add_parser(
        'replay', help="publish a bag's clouds to the live node at the recorded rate"
    )
    p.add_argument('bag')
    p.add_argument('--rate-factor', type=float, default=1.0, help='2.0 plays twice as fast')
    p.add_argument('--topics', nargs='*', default=None)
    p.add_argument(
        '--keep-stamps',
        action='store_true',
        help='publish the recorded stamps instead of the current time',
    )
    p.set_defaults(func=_replay)


def _replay(args) -> int:
    import rclpy
    from pcrp_ros.spinning import init_stopping_on_signals

    # Ctrl-C stops the replay between two clouds. rclpy's own handlers would shut the context
    # down under the next publish instead (a traceback), with the node still in it.
    init_stopping_on_signals()
    node = rclpy.create_node('pcrp_replay')
    n = 0
    try:
        n = replay(node, args.bag, args.rate_factor, not args.keep_stamps, args.topics,
                   on_start=lambda k: print(f'replaying {k} clouds from {args.bag} '
                                            '(Ctrl-C stops)', flush=True))
        print(f'published {n} clouds from {args.bag}')
    except KeyboardInterrupt:
        print('replay stopped')
        return 0
    finally:
        node.destroy_node()
        rclpy.try_shutdown()
    return 0 if n else 1


def register(sub) -> None:
    for r in (register_make_bag, register_process, register_replay):
        r(sub)
