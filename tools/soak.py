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

"""
Soak: the node as its own process, fed a mix of good and bad clouds, then held to account.

Fed on several topics at a steady rate; held to account: every cloud sent is received, every bad
one refused under its reason, every good one answered, refused for fit or dropped as stale, memory
flat, no crash, and a clean exit on Ctrl-C.

`python -m tools soak` runs it (10 minutes, 4 topics, 10 Hz by default); the test suite runs a
short one.
"""
from __future__ import annotations

from collections import Counter
import os
from pathlib import Path
import shutil
import signal
import subprocess
import sys
import tempfile
import threading
import time

import numpy as np
from tools.bad_clouds import CASES, good_cloud, GoodCloud

NODE_NAME = 'pcrp_soak_node'
SCENE_TOPIC = 'pcrp_soak/depth'
# a segmenter publishes a frame's objects after its depth cloud, by at least this much: a 3.7 MB
# depth cloud published back to back with its objects can arrive after them
SEGMENTER_SECONDS = 0.03
# runs shorter than this do not judge memory: a few seconds after start the node has not answered
# enough to have grown its buffers, and a 15-second run failed on that alone (+10 % after 3 s)
MEMORY_JUDGED_FROM_SECONDS = 60.0
FOCAL_PX = 600.0    # the depth frames' camera, in pixels
# Fast DDS reads the file this variable names when a process creates its first participant
PROFILE_VARIABLE = 'FASTRTPS_DEFAULT_PROFILES_FILE'
LARGE_CLOUDS_PROFILE = Path(__file__).resolve().parents[1] / 'config' / 'fastdds_large_clouds.xml'
_driver_profile_in_use: list = []


def use_driver_profile(profile: str | None) -> None:
    """
    Give the driver's DDS participant a Fast DDS profile (None: Fast DDS's defaults).

    The driver stands for the segmenter publishing the clouds, the side
    config/fastdds_large_clouds.xml is meant for. Fast DDS reads the profile once per process,
    so every run in one process must ask for the same one.
    """
    profile = str(profile) if profile else None
    if _driver_profile_in_use and _driver_profile_in_use[0] != profile:
        raise ValueError(f'this process already published with the Fast DDS profile '
                         f'{_driver_profile_in_use[0]}; one profile per process')
    _driver_profile_in_use[:] = [profile]
    if profile:
        os.environ[PROFILE_VARIABLE] = profile


def refused_on_arrival():
    """
    Return the bad cases with exactly one allowed outcome, a rejection made before queueing.

    So it is counted whatever the load: reason -> case.
    """
    out = {}
    for c in CASES:
        if len(c.allowed) == 1:
            (outcome,) = c.allowed
            if outcome.startswith('rejected:') and outcome != 'rejected:low_confidence':
                out.setdefault(outcome.split(':', 1)[1], c)
    return out


class _NodeProcesses:
    """
    k node processes, each answering its share of the topics (round robin).

    As a user scales out: one model file, several processes, topics split between them by
    parameter.
    """

    def __init__(self, topics, k: int, model_path, workers: int = 1, params: dict | None = None):
        self.workers = workers
        self.params = dict(params or {})
        self.dir = Path(tempfile.mkdtemp(prefix='pcrp_soak_'))
        self.names = [NODE_NAME if k == 1 else f'{NODE_NAME}_{i}' for i in range(k)]
        self.share = {name: topics[i::k] for i, name in enumerate(self.names)}
        self.procs = [self._start(name, model_path) for name in self.names]

    def _start(self, name, model_path):
        params = self.dir / f'{name}.yaml'
        lines = [
            f'{name}:',
            '  ros__parameters:',
            f"    input_topics: [{', '.join(self.share[name])}]",
            f'    workers: {self.workers}',
        ]
        if model_path:
            lines.append(f"    model_path: '{model_path}'")
        lines += [f'    {k}: {v}' for k, v in self.params.items()]
        params.write_text('\n'.join(lines) + '\n')
        cmd = [
            sys.executable,
            '-m',
            'pcrp_ros.node',
            '--ros-args',
            '-r',
            f'__node:={name}',
            '--params-file',
            str(params),
        ]
        # the node runs as it would without the driver's profile (see use_driver_profile)
        env = dict(os.environ)
        given = _driver_profile_in_use[0] if _driver_profile_in_use else None
        if given and env.get(PROFILE_VARIABLE) == given:
            del env[PROFILE_VARIABLE]
        return subprocess.Popen(
            cmd, stdout=(self.dir / f'{name}.log').open('w'), stderr=subprocess.STDOUT, env=env
        )

    def diagnostic_names(self) -> dict:
        # statuses are named by the node's full name and the resolved topic
        return {f'/{name}: /{t}': t for name in self.names for t in self.share[name]}

    def alive(self) -> bool:
        return all(p.poll() is None for p in self.procs)

    def rss_mb(self) -> float:
        """Return the node processes' resident memory, their worker processes' included."""
        from tools.process_memory import tree_rss_mb
        return sum(tree_rss_mb(p.pid) for p in self.procs)

    def stop(self) -> list[int]:
        """Ctrl-C each, as a user would; exit codes (killed ones count as -9)."""
        codes = []
        for p in self.procs:
            if p.poll() is None:
                p.send_signal(signal.SIGINT)
        for p in self.procs:
            try:
                codes.append(p.wait(timeout=20))
            except subprocess.TimeoutExpired:
                p.kill()
                codes.append(p.wait())
        return codes

    def log(self) -> str:
        return ''.join((self.dir / f'{n}.log').read_text(errors='replace') for n in self.names)


class _Diagnostics:
    """The node's latest /diagnostics values per topic."""

    def __init__(self, client, names: dict):
        from diagnostic_msgs.msg import DiagnosticArray
        self.values = {}
        self._names = names
        client.create_subscription(DiagnosticArray, '/diagnostics', self._on, 10)

    def _on(self, arr):
        for s in arr.status:
            if s.name in self._names:
                self.values[self._names[s.name]] = {kv.key: kv.value for kv in s.values}

    def get(self, topic, key, default=0.0) -> float:
        return float(self.values.get(topic, {}).get(key, default))


def camera_clouds(n: int, bag=None) -> list[GoodCloud]:
    """
    Return the first n depth-camera views of the shipped gallery in a bag (`pcrp make-bag`).

    By default the shipped demo bag's: what the node meets when run as `make demo` runs it
    (thousands of points each, not a few hundred).
    """
    from pcrp_ros.bags import read_bag
    from pcrp_ros.demo import DEMO_BAG

    clouds, truths, _ = read_bag(DEMO_BAG if bag is None else bag)
    out = []
    for c in clouds[:n]:
        hdr = c['msg'].header
        gt = truths.get((c['topic'], hdr.stamp.sec, hdr.stamp.nanosec), {})
        out.append(GoodCloud(np.asarray(c['points'], dtype=np.float64), gt.get('gallery_id', ''),
                             np.asarray(gt.get('rotation', np.eye(3)))))
    return out


def _table_depth(goods: list[GoodCloud]) -> float:
    """Return the depth of a table 5 cm behind the farthest object."""
    return max(float(g.points[:, 2].max()) for g in goods) + 0.05


def depth_cloud(goods: list[GoodCloud], width: int = 640, height: int = 480):
    """
    Make a camera's whole depth cloud, organized, without a stamp: a table just behind the objects.

    Every pixel of a 640 x 480 camera (f = FOCAL_PX) measures a plane 5 cm behind the farthest
    object, so the whole of it lies in reach of every answer: the most the node reads and cuts per
    cloud.
    """
    from pcrp_ros.conversions import xyz_to_pointcloud2
    from std_msgs.msg import Header

    v, u = np.mgrid[0:height, 0:width]
    rays = np.stack([(u - width / 2) / FOCAL_PX, (v - height / 2) / FOCAL_PX, np.ones(u.shape)],
                    -1)
    msg = xyz_to_pointcloud2(rays.reshape(-1, 3) * _table_depth(goods), Header())
    msg.height, msg.width, msg.row_step = height, width, width * msg.point_step
    return msg


def depth_image(goods: list[GoodCloud], width: int = 640, height: int = 480):
    """
    Make depth_cloud's frame as a driver's depth image (16UC1 millimetres) and its CameraInfo.

    Without stamps; 0.6 MB where the depth cloud is 3.7 MB.
    """
    from sensor_msgs.msg import CameraInfo, Image

    far_mm = round(1000 * _table_depth(goods))
    image = Image(height=height, width=width, encoding='16UC1', is_bigendian=0, step=2 * width,
                  data=np.full((height, width), far_mm, '<u2').tobytes())
    info = CameraInfo(height=height, width=width,
                      k=[FOCAL_PX, 0.0, width / 2, 0.0, FOCAL_PX, height / 2, 0.0, 0.0, 1.0])
    return image, info


def run(duration: float = 600.0, rate: float = 10.0, n_topics: int = 4, bad_share: float = 0.2,
        model_path: str | None = None, seed: int = 0, processes: int = 1, progress=print,
        workers: int = 1, reliable: bool = False, driver_profile: str | None = None,
        node_params: dict | None = None, bag=None, scene: str | None = None) -> dict:
    from geometry_msgs.msg import PoseStamped
    from pcrp_core import PCRP
    from pcrp_ros.conversions import xyz_to_pointcloud2
    from pcrp_ros.depth_images import camera_info_topic
    import rclpy
    from rclpy.executors import SingleThreadedExecutor
    from rclpy.qos import QoSProfile
    from sensor_msgs.msg import CameraInfo, PointCloud2
    from std_msgs.msg import Header

    model = PCRP.load(model_path)
    rng = np.random.default_rng(seed)
    goods = (camera_clouds(16, bag) if model_path is None else
             [good_cloud(model, seed=s, gallery_index=int(i))
              for s, i in enumerate(rng.choice(len(model.gallery_ids), 16, replace=False))])
    bads = refused_on_arrival()
    topics = [f'pcrp_soak/object_{k}' for k in range(n_topics)]
    use_driver_profile(driver_profile)
    params = dict(node_params or {})
    if reliable:
        # the node's accounting alone: nothing lost on the way, as a reliable replay gives
        params.update(qos_reliability='reliable', qos_depth=100)
    if scene:
        params.update(scene_topics=f'[{SCENE_TOPIC}]', scene_type=scene)
    nodes = _NodeProcesses(topics, processes, model_path, workers, params)

    rclpy.init()
    client = rclpy.create_node('pcrp_soak_driver')
    diag = _Diagnostics(client, nodes.diagnostic_names())
    poses = Counter()
    for t in topics:
        client.create_subscription(PoseStamped, f'/{t}/pose', lambda m, t=t: poses.update([t]), 50)
    pubs = {t: client.create_publisher(PointCloud2, f'/{t}', QoSProfile(depth=10)) for t in topics}
    depth = depth_cloud(goods) if scene == 'points' else None
    if scene == 'depth_image':
        depth, camera_info = depth_image(goods)
        info_pub = client.create_publisher(CameraInfo, f'/{camera_info_topic(SCENE_TOPIC)}',
                                           QoSProfile(depth=10))
    if scene:
        pubs[SCENE_TOPIC] = client.create_publisher(type(depth), f'/{SCENE_TOPIC}',
                                                    QoSProfile(depth=10))
    executor = SingleThreadedExecutor()
    executor.add_node(client)
    spin = threading.Thread(target=executor.spin, daemon=True)
    spin.start()
    sent = {t: Counter() for t in topics}
    rss = []
    try:
        deadline = time.monotonic() + 60.0
        while time.monotonic() < deadline and not all(
            p.get_subscription_count() for p in pubs.values()
        ):
            if not nodes.alive():
                raise RuntimeError(f'a node exited at start-up; see the logs in {nodes.dir}')
            time.sleep(0.1)
        # the driver sees the match before the node's reader has seen the writer: give discovery
        # a moment, or the first clouds are lost on the way
        time.sleep(2.0)
        progress(
            f'soak: {processes} node process(es) up ({workers} worker(s) each); '
            f'{n_topics} topics at {rate:g} Hz for {duration:g} s, '
            f'{bad_share:.0%} bad clouds'
        )
        bad_cycle = list(bads.items())
        t0 = next_rss = time.monotonic()
        tick = late = 0
        while time.monotonic() - t0 < duration:
            # a tick sent half a period late is the driver's stall, not the node's: the clouds it
            # owes then go out back to back, a burst no camera sends
            late += time.monotonic() - (t0 + tick / rate) > 0.5 / rate
            frame = Header(stamp=client.get_clock().now().to_msg(),
                           frame_id='camera_optical_frame')
            if scene:   # one camera frame: its depth frame, then the objects cut from it
                depth.header = frame
                if scene == 'depth_image':
                    camera_info.header = frame
                    info_pub.publish(camera_info)
                pubs[SCENE_TOPIC].publish(depth)
                time.sleep(SEGMENTER_SECONDS)
            for k, t in enumerate(topics):
                header = frame if scene else Header(
                    stamp=client.get_clock().now().to_msg(), frame_id='camera_optical_frame'
                )
                if rng.random() < bad_share:
                    reason, case = bad_cycle[(tick * n_topics + k) % len(bad_cycle)]
                    pubs[t].publish(case.make(goods[0], header))
                    sent[t]['bad'] += 1
                    sent[t][f'bad_{reason}'] += 1
                else:
                    g: GoodCloud = goods[(tick + k) % len(goods)]
                    pubs[t].publish(xyz_to_pointcloud2(g.points, header))
                    sent[t]['good'] += 1
            tick += 1
            now = time.monotonic()
            if now >= next_rss:
                rss.append((now - t0, nodes.rss_mb()))
                next_rss += max(1.0, duration / 60)
                if len(rss) % 10 == 0:
                    progress(
                        f'soak: {now - t0:5.0f} s, '
                        f"sent {sum(s['good'] + s['bad'] for s in sent.values())}, "
                        f"answered {int(sum(diag.get(x, 'answered') for x in topics))}, "
                        f'rss {rss[-1][1]:.0f} MB'
                    )
            time.sleep(max(0.0, t0 + tick / rate - time.monotonic()))
            if not nodes.alive():
                break
        rss.append((time.monotonic() - t0, nodes.rss_mb()))
        # let the worker finish its last cloud and diagnostics catch up with everything sent
        settle = time.monotonic() + 30.0

        def total(t):
            return sum(diag.get(t, k) for k in ('answered', 'rejected', 'dropped_stale'))

        while (
            time.monotonic() < settle
            and nodes.alive()
            and not all(
                diag.get(t, 'received') == sent[t]['good'] + sent[t]['bad']
                and total(t) == diag.get(t, 'received')
                for t in topics
            )
        ):
            time.sleep(0.5)
        time.sleep(1.5)   # one more diagnostics period, so the figures read are final
        alive = nodes.alive()
        codes = nodes.stop()
    finally:
        executor.shutdown(timeout_sec=2.0)
        # a spinning thread left at exit aborts the interpreter (std::terminate)
        spin.join(timeout=5.0)
        client.destroy_node()
        rclpy.try_shutdown()
        for p in nodes.procs:
            if p.poll() is None:
                p.kill()
    code = max(codes, key=abs)
    result = _summarise(
        topics,
        sent,
        diag,
        poses,
        rss,
        alive,
        code,
        nodes.log(),
        duration,
        rate,
        bad_share,
        str(nodes.dir),
        scene,
    )
    result['processes'] = processes
    result['workers'] = workers
    if result['passed']:   # the node logs are kept only to explain a failure
        shutil.rmtree(nodes.dir, ignore_errors=True)
        result['node_log'] = None
    result['driver_late_ticks'] = late
    result['driver_profile'] = Path(driver_profile).name if driver_profile else None
    return result


def _summarise(
    topics, sent, diag, poses, rss, alive, code, log, duration, rate, bad_share, log_path,
    scene=None
) -> dict:
    per_topic = {}
    checks = {
        'no crash (alive at the end, exit 0 on Ctrl-C, no traceback)': alive
        and code == 0
        and 'Traceback' not in log
    }
    for t in topics:
        d = {
            k: diag.get(t, k)
            for k in (
                'received',
                'answered',
                'rejected',
                'dropped_stale',
                'rejected_low_confidence',
                'latency_p50_ms',
                'latency_p95_ms',
                'age_p50_ms',
                'age_p95_ms',
            )
        }
        if scene:
            d.update({k: diag.get(t, k) for k in ('scene_used', 'scene_missing')})
        s = sent[t]
        bad_counted = all(
            diag.get(t, f'rejected_{k[4:]}') == v for k, v in s.items() if k.startswith('bad_')
        )
        good_accounted = (
            d['answered'] + d['rejected_low_confidence'] + d['dropped_stale'] == s['good']
        )
        per_topic[t] = {'sent_good': s['good'], 'sent_bad': s['bad'], **d, 'poses_seen': poses[t]}
        checks[f'{t}: every cloud sent was received'] = d['received'] == s['good'] + s['bad']
        checks[f'{t}: every bad cloud counted under its reason'] = bad_counted
        checks[f'{t}: every good cloud answered, refused for fit or dropped stale'] = (
            good_accounted
        )
        checks[f'{t}: a pose published for every answer'] = poses[t] == d['answered']
        if scene:
            # best-effort transport may lose a frame's depth cloud (3.7 MB): then its clouds are
            # answered without one, counted as missing
            checks[f'{t}: every good cloud estimated counted with its depth frame or without'] = (
                d['scene_used'] + d['scene_missing']
                == d['answered'] + d['rejected_low_confidence'])
    warm = [m for s, m in rss if s >= 0.2 * duration] or [m for _, m in rss]
    growth = warm[-1] / warm[0] - 1.0 if warm else float('nan')
    if duration >= MEMORY_JUDGED_FROM_SECONDS:
        checks['resident memory flat within 10 % after warm-up'] = bool(abs(growth) <= 0.10)
    return {
        'duration_s': duration,
        'rate_hz': rate,
        'topics': len(topics),
        'bad_share': bad_share,
        'per_topic': per_topic,
        'rss_mb': [(round(s, 1), round(m, 1)) for s, m in rss],
        'rss_start_mb': rss[0][1] if rss else float('nan'),
        'rss_warm_mb': warm[0] if warm else float('nan'),
        'rss_end_mb': rss[-1][1] if rss else float('nan'),
        'rss_growth_after_warmup': growth,
        'exit_code': code,
        'node_log': log_path,
        'checks': checks,
        'passed': all(checks.values()),
    }


def table(result: dict) -> str:
    rows = [
        '| topic | good sent | bad sent | received | answered | refused (fit) '
        '| refused (bad input) | dropped stale | latency p50 / p95 ms | age p50 / p95 ms |',
        '|---|---|---|---|---|---|---|---|---|---|',
    ]
    for t, d in result['per_topic'].items():
        bad = d['rejected'] - d['rejected_low_confidence']
        rows.append(
            f"| {t} | {d['sent_good']} | {d['sent_bad']} | {d['received']:.0f} "
            f"| {d['answered']:.0f} "
            f"| {d['rejected_low_confidence']:.0f} | {bad:.0f} | {d['dropped_stale']:.0f} "
            f"| {d['latency_p50_ms']:.0f} / {d['latency_p95_ms']:.0f} "
            f"| {d['age_p50_ms']:.0f} / {d['age_p95_ms']:.0f} |"
        )
    rows.append('')
    scenes = [f"{t} used {d['scene_used']:.0f}, missing {d['scene_missing']:.0f}"
              for t, d in result['per_topic'].items() if 'scene_used' in d]
    if scenes:
        rows += ['Clouds estimated with their depth frame: ' + '; '.join(scenes) + '.', '']
    who = (
        'the node'
        if result.get('processes', 1) == 1
        else f"the {result['processes']} node processes together"
    )
    rows.append(
        f"Resident memory of {who}: {result['rss_start_mb']:.0f} MB at start, "
        f"{result['rss_warm_mb']:.0f} MB after warm-up (20 % of the run), "
        f"{result['rss_end_mb']:.0f} MB at the end "
        f"({100 * result['rss_growth_after_warmup']:+.1f} % after warm-up). "
        f"Exit code on Ctrl-C: {result['exit_code']}."
    )
    rows.append('')
    rows += [f"- {'pass' if ok else 'FAIL'}: {name}" for name, ok in result['checks'].items()]
    if result.get('node_log'):
        rows += ['', f"The node's log: {result['node_log']}"]
    return '\n'.join(rows)


def register(sub) -> None:
    p = sub.add_parser(
        'soak', help='run the node for a while on good and bad clouds and check it held up'
    )
    p.add_argument('--duration', type=float, default=600.0, help='seconds of publishing')
    p.add_argument('--rate', type=float, default=10.0, help='clouds per second on each topic')
    p.add_argument('--topics', type=int, default=4)
    p.add_argument('--bad-share', type=float, default=0.2)
    p.add_argument('--processes', type=int, default=1, help='node processes sharing the topics')
    p.add_argument('--workers', type=int, default=1, help="the node's workers parameter")
    p.add_argument('--model', default=None)
    p.add_argument('--json', default=None, help='also write the figures to this JSON file')
    p.add_argument('--bag', default=None,
                   help='camera views of the shipped gallery to publish (`pcrp make-bag`; '
                        'default: the demo bag); with --model, views cut from its gallery')
    p.add_argument('--driver-profile', default=None,
                   help='Fast DDS profile the clouds are published with (default: Fast DDS '
                        f'defaults; {LARGE_CLOUDS_PROFILE.name} for bursts of large clouds)')
    p.add_argument('--scene', nargs='?', const='points', default=None,
                   choices=('points', 'depth_image'),
                   help="also publish each frame's whole depth frame (640 x 480) and give the "
                   'node scene_topics: as a depth cloud (points, the default) or a depth image '
                   'and its CameraInfo (depth_image); the topics then share one stamp per frame')
    p.set_defaults(func=_soak)


def _soak(args) -> int:
    import json
    result = run(
        args.duration,
        args.rate,
        args.topics,
        args.bad_share,
        args.model,
        processes=args.processes,
        workers=args.workers,
        driver_profile=args.driver_profile,
        bag=args.bag,
        scene=args.scene,
    )
    print(table(result))
    if args.json:
        Path(args.json).write_text(json.dumps(result, indent=1))
    return 0 if result['passed'] else 1
