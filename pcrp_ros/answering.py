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
Answering object clouds: everything the plain and the managed node share.

A CloudAnswerer lives inside a node (rclpy.node.Node or rclpy.lifecycle.LifecycleNode) and
does the work in four steps that map onto the lifecycle transitions:

- configure: read the parameters, load and check the model, start the workers;
- activate: subscribe to every input topic, create the publishers and /diagnostics, and
  start answering;
- deactivate: stop answering and remove the subscriptions and publishers;
- cleanup: stop the workers and free the model.

The plain node runs configure and activate in its constructor. Clouds are checked on arrival
(cheap), so every unusable one is refused and counted under its reason however busy the
workers are; usable ones wait in a short queue per topic (`queue_size`: a cloud arriving at a
full queue pushes out its oldest, counted as dropped_stale, so a slow model never builds a
backlog), and `workers` threads answer the topics in turn.

With `scene_topics`, each cloud is answered with the camera's whole depth cloud of the same
stamp and frame (pcrp_ros/scenes.py), cropped to what the estimate can use. The scene is looked
up when the cloud is queued (the scene message is kept with it, unread) and, if none had come
yet, again when a worker takes the cloud; it is read only then. A cloud whose scene is missing
or unusable is answered without one: counted, and logged as rejections are.

A program that runs the node in its own process may set `on_answer`, a callable told
(topic, header, PoseResult) of every estimate, rejected ones too, from the worker thread that made
it (the demo shows each cloud's confidence so). What it raises is logged, throttled, and the
stream goes on.
"""

from __future__ import annotations

import collections
from pathlib import Path
import sys
import threading
import time
from typing import NamedTuple

from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
import numpy as np
from pcrp_core import InvalidCloud
from pcrp_core.config import InstanceOptions, PoseOptions, QueryOptions
from pcrp_ros.conversions import aligned_points, CloudFormatError, detections_msg
from pcrp_ros.conversions import pointcloud2_to_xyz, pose_stamped, xyz_to_pointcloud2
from pcrp_ros.depth_images import camera_info_topic
from pcrp_ros.engine import Engine, load_engine, LOAD_ERRORS, ReloadRequest
from pcrp_ros.parameters import descriptor, MODEL_SETTINGS, NodeSettings, parameters, ros_value
from pcrp_ros.parameters import unknown_overrides
from pcrp_ros.scenes import Scenes
from pcrp_ros.stats import StreamStats
from pcrp_ros.workers import ProcessEstimator, WorkerDied
from rcl_interfaces.msg import SetParametersResult
from rclpy.callback_groups import MutuallyExclusiveCallbackGroup
from rclpy.parameter import Parameter
from rclpy.qos import HistoryPolicy, qos_profile_sensor_data, QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import CameraInfo, Image, PointCloud2
from std_msgs.msg import String
from std_srvs.srv import Trigger

# seconds between two attempts to restart a worker process that could not be restarted
RESTART_BACKOFF = 10.0
# seconds the reload service waits for the new model before answering
RELOAD_WAIT = 600.0
# The executor thread takes every cloud from DDS while a worker thread of the same process answers
# another (in every node: run as an executable, by `pcrp demo` or in a test). The worker holds the
# GIL between numpy calls, and at Python's default 5 ms switch interval the executor waits up to
# that long each of the many times it retakes the GIL, so the reader's queue overflowed and clouds
# were lost before they were taken (two topics at 10 Hz on the four-category model: 464 of 800
# clouds received; 798 at 0.5 ms).
GIL_SWITCH_INTERVAL_S = 0.0005
# what an auto scene topic's publishers may send, and how often to look for them until one is seen
SCENE_KINDS = {'sensor_msgs/msg/Image': 'depth_image', 'sensor_msgs/msg/PointCloud2': 'points'}
SCENE_LOOKUP_S = 0.2


class Waiting(NamedTuple):
    """A checked cloud waiting to be answered."""

    header: object
    points: object                  # what PCRP.screen made of the cloud
    received: float                 # time.monotonic() on arrival
    scene: object = None            # the scene message found when it was queued, unread


class CloudAnswerer:
    """The streams, the workers and the model of one node; see the module docstring."""

    def __init__(self, node):
        self.node = node
        for spec in parameters():
            node.declare_parameter(spec['name'], ros_value(spec['default']), descriptor(spec))
        # a `[]` in a params file leaves a list parameter declared without a type unset (None)
        values = {spec['name']: _or_default(self._param(spec['name']), spec['default'])
                  for spec in parameters()}
        # ValueError saying which is wrong, before anything is loaded
        self.settings = NodeSettings(**{k: values[k] for k in NodeSettings.__dataclass_fields__})
        self._params = {k: values[k] for k in MODEL_SETTINGS}
        _check_model_settings(self._params)
        self._up = _checked_up(values['up_vector'], None)
        unknown = unknown_overrides(node)
        if unknown:
            self._log().warning('parameters this node does not have, ignored: '
                                f"{', '.join(unknown)}")
        self.engine = None
        self.stats: dict[str, StreamStats] = {}
        self._resolved = {}
        self._pubs = {}
        self._subs = []
        self._scenes = Scenes(self.settings.scene_topic_of())
        self._scene_subs = []
        self._scene_kinds = {}    # scene topic -> what it carries, once subscribed
        self._scene_timer = None  # looks for the publishers of auto scene topics
        self._scene_lock = threading.Lock()   # the timer's subscribing against deactivate
        self._diag = None
        self._timer = None
        self._service = None
        self._cv = threading.Condition()
        self._slots = {}          # topic -> clouds waiting, oldest first
        self._served = {}         # topic -> when a worker last took one of its clouds
        self._threads = []
        self._running = False
        self._retired = []
        self._last_log = {}
        self._model_problem = ''
        self._reload_lock = threading.Lock()
        self._pending = None
        self._reloader = None
        self.on_answer = None     # (topic, header, PoseResult) of every estimate; see above
        node.add_on_set_parameters_callback(self._on_set_parameters)
        node.add_post_set_parameters_callback(self._on_parameters_set)

    def _param(self, name: str):
        return self.node.get_parameter(name).value

    def _log(self):
        return self.node.get_logger()

    # -- lifecycle ----------------------------------------------------------------------------
    def configure(self, model=None) -> None:
        """Load and check the model and start the workers; LOAD_ERRORS saying why not."""
        path = self._param('model_path')
        self.engine = load_engine(path, dict(self._params), self._up, self.settings.workers, model)
        self._model_problem = ''
        self._service = self.node.create_service(
            Trigger, '~/reload_model', self._on_reload_service,
            callback_group=MutuallyExclusiveCallbackGroup())
        self._log().info(f'model: {self.engine.describe()}, {self._workers_text()}')
        # what this node was told, in the log a robot keeps, beside the model it answers with (a
        # start that fails says only why)
        told = []
        for spec in parameters():
            value = _or_default(self._param(spec['name']), spec['default'])
            if value != ros_value(spec['default']):
                told.append(f"{spec['name']} {value}")
        if told:
            self._log().info(f"parameters set: {', '.join(told)}")

    def activate(self) -> None:
        """Subscribe, create the publishers and /diagnostics, start answering."""
        s = self.settings
        qos = self._input_qos()
        out_qos = QoSProfile(depth=10)   # reliable: a planner must not miss a pose
        for topic in s.input_topics:
            # A group per topic: in one shared group the executor takes one cloud per wait and
            # always tries the topics in the same order, so under load the last topic's reader
            # queue overflowed unseen (4 topics at 20 Hz, one worker: 787 of 2,400 clouds
            # received on it, 2,361 with a group each).
            sub = self.node.create_subscription(
                PointCloud2, topic, lambda msg, t=topic: self._on_cloud(t, msg), qos,
                callback_group=MutuallyExclusiveCallbackGroup())
            self._subs.append(sub)
            resolved = self._resolved[topic] = sub.topic_name
            pubs = {'pose': self.node.create_publisher(PoseStamped, f'{resolved}/pose', out_qos),
                    'gallery_id': self.node.create_publisher(
                        String, f'{resolved}/gallery_id', out_qos),
                    'aligned_model': self.node.create_publisher(
                        PointCloud2, f'{resolved}/aligned_model', out_qos)}
            try:
                from vision_msgs.msg import Detection3DArray
                pubs['detections'] = self.node.create_publisher(
                    Detection3DArray, f'{resolved}/detections', out_qos)
            except ImportError:
                pass
            self._pubs[topic] = pubs
            self.stats.setdefault(topic, StreamStats())
        with self._scene_lock:
            self._scene_kinds = {}
            self._subscribe_scenes_known()
            if self._waiting_scenes():   # auto, no publisher seen yet
                self._scene_timer = self.node.create_timer(SCENE_LOOKUP_S, self._subscribe_scenes)
        self._diag = self.node.create_publisher(DiagnosticArray, '/diagnostics', 10)
        self._timer = self.node.create_timer(1.0, self.publish_diagnostics)
        with self._cv:
            self._running = True
        sys.setswitchinterval(GIL_SWITCH_INTERVAL_S)   # for the whole process: see above
        self._threads = [threading.Thread(target=self._work, args=(k,), daemon=True,
                                          name=f'pcrp_answer_{k}')
                         for k in range(self.settings.workers)]
        for t in self._threads:
            t.start()
        # the model's line (configure) has named the gallery
        self._log().info(f"listening on {', '.join(sub.topic_name for sub in self._subs)}"
                         f'{self._scenes_text()}')

    def deactivate(self) -> None:
        """
        Stop answering and remove the subscriptions and publishers.

        A cloud being answered is finished, not published.
        """
        with self._cv:
            self._running = False
            for topic, waiting in self._slots.items():   # received, never to be answered
                for _ in waiting:
                    self.stats[topic].count('dropped_stale')
            self._slots.clear()
            self._cv.notify_all()
        for t in self._threads:
            t.join(timeout=60.0)
        self._threads = []
        pubs, self._pubs = self._pubs, {}
        with self._scene_lock:
            for sub in self._subs + self._scene_subs:
                self.node.destroy_subscription(sub)
            self._subs, self._scene_subs = [], []
            self._cancel_scene_timer()
            self._scene_kinds = {}
        self._scenes.clear()
        for group in pubs.values():
            for pub in group.values():
                self.node.destroy_publisher(pub)
        if self._timer is not None:
            self.node.destroy_timer(self._timer)
            self._timer = None
        if self._diag is not None:
            self.node.destroy_publisher(self._diag)
            self._diag = None
        self._close_retired()

    def cleanup(self) -> None:
        """Stop the workers and free the model (after any switch under way has ended)."""
        with self._reload_lock:
            reloader = self._reloader
        if reloader is not None:
            reloader.join(timeout=RELOAD_WAIT)
        with self._cv:
            engine, self.engine = self.engine, None
        if engine is not None:
            engine.close()
        self._close_retired()
        if self._service is not None:
            self.node.destroy_service(self._service)
            self._service = None

    @property
    def active(self) -> bool:
        return self._running

    @property
    def scenes(self) -> Scenes:
        """Return the scene messages and CameraInfo held (to look at, not to change)."""
        return self._scenes

    def _close_retired(self) -> None:
        with self._cv:
            retired, self._retired = self._retired, []
        for engine in retired:
            engine.close()

    # -- parameters ---------------------------------------------------------------------------
    def _on_set_parameters(self, params) -> SetParametersResult:
        for p in params:
            # what can be told at once is: the rest of a model's checks come as it loads (reload)
            if p.name == 'model_path' and p.value and not Path(p.value).is_dir():
                return SetParametersResult(successful=False, reason=(
                    f'{p.value}: no such model directory (a model is a directory holding '
                    'model.json and arrays.npz)'))
        changes = {p.name: p.value for p in params if p.name in MODEL_SETTINGS}
        up = [p.value for p in params if p.name == 'up_vector']
        with self._cv:
            engine = self.engine
            try:
                new_up = _checked_up(up[0], engine and engine.model) if up else self._up
                if engine is not None:
                    engine.model.set_params(**changes)   # checks every value before setting any
                else:
                    _check_model_settings({**self._params, **changes})
            except ValueError as e:
                return SetParametersResult(successful=False, reason=str(e))
            self._up = new_up
            self._params.update(changes)
        return SetParametersResult(successful=True)

    def _on_parameters_set(self, params) -> None:
        """Switch models when model_path was set to another path while a model is loaded."""
        for p in params:
            if p.name == 'model_path' and self.engine is not None and p.value != self.engine.path:
                self.reload(p.value, from_parameter=True)

    # -- switching models ---------------------------------------------------------------------
    def reload(self, path: str, from_parameter: bool = False) -> ReloadRequest:
        """
        Load the model at path beside the current one, off the callback thread.

        They are swapped once it is ready; a newer request replaces one still waiting.
        """
        request = ReloadRequest(path, from_parameter)
        with self._reload_lock:
            if self._pending is not None:
                self._pending.finish(False, f'superseded by a request for {path!r}')
            self._pending = request
            if self._reloader is None:
                self._reloader = threading.Thread(target=self._reload_loop, daemon=True,
                                                  name='pcrp_reload')
                self._reloader.start()
        return request

    def _reload_loop(self) -> None:
        while True:
            with self._reload_lock:
                request, self._pending = self._pending, None
                if request is None:
                    self._reloader = None
                    return
            try:
                self._switch(request)
            except Exception as e:  # the old model answers on whatever happened here
                request.finish(False, f'{type(e).__name__}: {e}')

    def _switch(self, request: ReloadRequest) -> None:
        old = self.engine
        if old is None:
            request.finish(False, 'no model is loaded (the node is not configured)')
            return
        where = request.path or 'the shipped default model'
        self._log().info(f'loading {where}; {old.describe()} answers meanwhile')
        try:
            engine = load_engine(request.path, dict(self._params), self._up,
                                 self.settings.workers)
        except LOAD_ERRORS as e:
            why = str(e) or type(e).__name__
            self._model_problem = f'could not switch to {where}: {why}'
            self._log().error(f'{self._model_problem}; still answering with {old.describe()}')
            request.finish(False, why)
            with self._reload_lock:
                newer = self._pending is not None
            if request.from_parameter and not newer:
                # the parameter says which model answers: back to the one still in use
                self.node.set_parameters([Parameter('model_path', value=old.path)])
            return
        with self._cv:
            if self.engine is not old:   # cleaned up or switched meanwhile
                swapped = False
            else:
                engine.model.set_params(**self._params)   # any change made while loading
                self.engine = engine
                self._retired.append(old)
                swapped = True
                self._cv.notify_all()
            running = self._running
        if not swapped:
            engine.close()
            request.finish(False, 'the node was cleaned up while the model loaded')
            return
        if not running:
            self._close_retired()
        self._model_problem = ''
        self._log().info(f'now answering with {engine.describe()}')
        request.finish(True, f'now answering with {engine.describe()}')

    def _on_reload_service(self, request, response):
        """~/reload_model: load model_path again (a model rebuilt in place) and swap."""
        reload = self.reload(self._param('model_path'))
        if reload.done.wait(RELOAD_WAIT):
            response.success, response.message = reload.ok, reload.message
        else:
            response.success = False
            response.message = (f'still loading after {RELOAD_WAIT:g} s; the outcome will be '
                                'logged and shown in /diagnostics')
        return response

    # -- receiving ----------------------------------------------------------------------------
    def _on_cloud(self, topic: str, msg: PointCloud2) -> None:
        """
        Refuse an unreadable cloud at once (cheap), or queue it.

        A cloud arriving at a full queue pushes out the topic's oldest waiting one.
        """
        received = time.monotonic()
        stats = self.stats[topic]
        stats.count('received')
        engine = self.engine
        if engine is None or not self._running:
            stats.count('dropped_stale')
            return
        try:
            points = engine.model.screen(pointcloud2_to_xyz(msg, finite_only=False))
        except (CloudFormatError, InvalidCloud) as e:
            self.reject(topic, e.reason, str(e))
            return
        except Exception as e:   # nothing one message holds may take the subscription down
            self.reject(topic, 'internal_error', f'{type(e).__name__}: {e}')
            return
        item = Waiting(msg.header, points, received, self._scenes.on_arrival(topic, msg.header))
        with self._cv:
            waiting = self._slots.setdefault(topic, collections.deque())
            dropped = 0
            while len(waiting) >= self.settings.queue_size:
                waiting.popleft()
                stats.count('dropped_stale')
                dropped += 1
            waiting.append(item)
            self._cv.notify()
        if dropped:
            self._warn_if_behind(topic, stats)

    def _warn_if_behind(self, topic: str, stats) -> None:
        """Log, once per log_throttle_sec, that a topic's clouds are dropped unanswered."""
        behind = stats.falling_behind()
        if behind and self._due((topic, 'falling_behind')):
            p50 = stats.snapshot().get('latency_p50_ms')
            took = f'; answers take {p50:.0f} ms at the median' if p50 is not None else ''
            self._log().warning(f'{topic}: {behind}{took}: give the node more `workers` (one '
                                'per core), send fewer clouds, or lighten its search '
                                '(docs/node.md, Workers)')

    def _next(self, k: int, engine):
        """
        Decide, under the lock, what worker k does next.

        One of ('stop',), ('switch', engine), ('restart',) or ('answer', topic, item).
        """
        while True:
            if not self._running:
                return ('stop',)
            if self.engine is not engine:
                return ('switch', self.engine)
            if k in engine.down:
                wait = engine.retry_at[k] - time.monotonic()
                if wait <= 0:
                    return ('restart',)
                self._cv.wait(min(wait, 1.0))
                continue
            if self._slots:
                # topics take turns: the one served longest ago first (then the oldest cloud).
                # Picking the oldest cloud alone starves all topics but one once the node falls
                # behind: every queue then holds only its newest clouds, and the topic published
                # first in each round always holds the oldest of them.
                topic = min(self._slots,
                            key=lambda t: (self._served.get(t, -1.0), self._slots[t][0].received))
                waiting = self._slots[topic]
                item = waiting.popleft()
                if not waiting:
                    del self._slots[topic]
                self._served[topic] = time.monotonic()
                return ('answer', topic, item)
            self._cv.wait()

    def _work(self, k: int) -> None:
        engine = None
        while True:
            with self._cv:
                step = self._next(k, engine)
            if step[0] == 'stop':
                break
            if step[0] == 'switch':
                if engine is not None:
                    engine.release(k)
                engine = step[1]
                continue
            if step[0] == 'restart':
                self._restart(engine, k)
                continue
            topic, item = step[1], step[2]
            try:
                self.answer(topic, item, engine, k)
            except WorkerDied as e:
                self.reject(topic, 'worker_died', f'{e}; restarting it')
                engine.down[k] = str(e)
                engine.retry_at[k] = time.monotonic()
            except Exception as e:   # the stream must survive anything one cloud does
                self.reject(topic, 'internal_error', f'{type(e).__name__}: {e}')
        if engine is not None and engine is not self.engine:
            engine.release(k)

    def _restart(self, engine: Engine, k: int) -> None:
        """Start worker k of the engine again after it died."""
        old = engine.estimators[k]
        if old is not None:
            old.close(timeout=1.0)
        try:
            engine.estimators[k] = ProcessEstimator(engine.path, dict(self._params))
        except LOAD_ERRORS as e:
            engine.estimators[k] = None
            engine.down[k] = f'could not be restarted: {e}'
            engine.retry_at[k] = time.monotonic() + RESTART_BACKOFF
            self._log().error(f'worker {k} {engine.down[k]}; trying again in '
                              f'{RESTART_BACKOFF:g} s')
            return
        engine.restarts += 1
        engine.down.pop(k, None)
        engine.retry_at.pop(k, None)
        self._log().info(f'worker {k} restarted (pid {engine.estimators[k].pid})')

    def reject(self, topic: str, reason: str, message: str) -> None:
        """
        Count a rejected cloud, and log once per topic and reason per log_throttle_sec.

        rclpy's own throttle is per call site, so one noisy reason would hide every other.
        """
        self.stats[topic].count('rejected', reason)
        if self._due((topic, reason)):
            total = self.stats[topic].rejections[reason]
            self._log().warning(f'{topic}: cloud rejected ({reason}, {total} so far): {message}')

    def _due(self, key) -> bool:
        """Tell whether a log line of this kind may be written now (then it is taken to be)."""
        now = time.monotonic()
        if now - self._last_log.get(key, -np.inf) < float(self._param('log_throttle_sec')):
            return False
        self._last_log[key] = now
        return True

    def answer(self, topic: str, item: Waiting, engine: Engine, k: int = 0) -> None:
        """Estimate one queued cloud with worker k of the engine and publish the answer."""
        header, received = item.header, item.received
        try:
            result = self._estimate(topic, item, engine, k)
        except InvalidCloud as e:
            self.reject(topic, e.reason, str(e))
            return
        stats = self.stats[topic]
        stats.estimated(result.timings, None if result.rejected else result.confidence,
                        result.stray_share)
        self._tell(topic, header, result)
        if result.rejected:
            self.reject(topic, 'low_confidence', result.reason)
            return
        pubs = self._pubs.get(topic)
        if pubs is None or not self._running:   # deactivated meanwhile: answer no more
            return
        pubs['pose'].publish(pose_stamped(result, header))
        pubs['gallery_id'].publish(String(data=result.gallery_id))
        if self._param('publish_aligned_model'):
            cloud = aligned_points(result, engine.model.gallery_cloud(result.gallery_id))
            pubs['aligned_model'].publish(xyz_to_pointcloud2(cloud, header))
        if 'detections' in pubs:
            det = detections_msg(result, header, engine.model.gallery_cloud(result.gallery_id))
            if det is not None:
                pubs['detections'].publish(det)
        stamp = header.stamp.sec + 1e-9 * header.stamp.nanosec
        now = self.node.get_clock().now().nanoseconds * 1e-9
        stats.timing(time.monotonic() - received, now - stamp)
        stats.count('answered')

    def _tell(self, topic: str, header, result) -> None:
        """Hand an estimate to on_answer, if set; nothing it raises stops the stream."""
        if self.on_answer is None:
            return
        try:
            self.on_answer(topic, header, result)
        except Exception as e:   # the caller's code: its failure must not cost the answer
            if self._due((topic, 'on_answer')):
                self._log().error(f'{topic}: on_answer raised {type(e).__name__}: {e}')

    def _estimate(self, topic: str, item: Waiting, engine: Engine, k: int):
        """
        Return worker k's PoseResult of the cloud, with its scene when it has a usable one.

        An estimate that fails with the scene (not for the cloud: InvalidCloud) is made again
        without it, so no scene costs a cloud its answer.
        """
        viewpoint = np.zeros(3) if self._param('sensor_at_origin') else None
        scene, outcome, why = self._scenes.scene(topic, item.header, item.points, item.scene,
                                                 engine.model, viewpoint)
        if why is not None:
            if outcome == 'missing' and self._scenes.topic_of[topic] not in self._scene_kinds:
                why = 'no publisher of it seen yet (scene_type auto subscribes once there is one)'
            self._without_scene(topic, outcome, why)
        estimate = engine.estimators[k].estimate
        try:
            if scene is not None:
                try:
                    return estimate(item.points, viewpoint, self._up, dict(self._params), scene)
                except (InvalidCloud, WorkerDied):   # the cloud's or the worker's fault
                    raise
                except Exception as e:   # the scene's or the core's: the cloud is still answered
                    outcome = self._without_scene(
                        topic, 'rejected_internal_error',
                        f'the estimate failed with it ({type(e).__name__}: {e})')
            return estimate(item.points, viewpoint, self._up, dict(self._params))
        finally:
            if outcome is not None:
                self.stats[topic].scene(outcome)

    def _input_qos(self) -> QoSProfile:
        s = self.settings
        reliability = (ReliabilityPolicy.BEST_EFFORT if s.qos_reliability == 'best_effort'
                       else ReliabilityPolicy.RELIABLE)
        return QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=s.qos_depth,
                          reliability=reliability, durability=qos_profile_sensor_data.durability)

    # -- scenes -------------------------------------------------------------------------------
    def _subscribe_scenes(self) -> None:
        """Look for the publishers of scene topics still waiting (the timer's call)."""
        with self._scene_lock:
            if self._scene_timer is not None:   # else deactivated since the timer fired
                self._subscribe_scenes_known()

    def _subscribe_scenes_known(self) -> None:
        """
        Subscribe each scene topic not yet subscribed whose message type is known.

        Known from scene_type, or with auto from the topic's publishers: a depth image comes with
        its CameraInfo beside it. Once every one is, the timer looking for them is cancelled.
        """
        qos = self._input_qos()
        for scene_topic in self._waiting_scenes():
            kind = self._scene_kind(scene_topic)
            if kind is None:
                continue
            self._scene_kinds[scene_topic] = kind
            images = kind == 'depth_image'
            self._scene_subs.append(self.node.create_subscription(
                Image if images else PointCloud2, scene_topic,
                lambda msg, t=scene_topic: self._scenes.buffer.add(t, msg), qos,
                callback_group=MutuallyExclusiveCallbackGroup()))
            self._resolved[scene_topic] = self._scene_subs[-1].topic_name
            if images:   # the camera's intrinsics, which drivers publish with each image
                self._scene_subs.append(self.node.create_subscription(
                    CameraInfo, camera_info_topic(self._resolved[scene_topic]),
                    lambda msg, t=scene_topic: self._scenes.on_camera_info(t, msg),
                    qos, callback_group=MutuallyExclusiveCallbackGroup()))
            self._log().info(f'scenes from {self._resolved[scene_topic]} ({kind})')
        if not self._waiting_scenes():
            self._cancel_scene_timer()

    def _waiting_scenes(self) -> list[str]:
        """Return the scene topics not subscribed yet, each once, in order."""
        return [t for t in dict.fromkeys(self.settings.scene_topics) if t not in self._scene_kinds]

    def _scene_kind(self, scene_topic: str) -> str | None:
        """Return points or depth_image for scene_topic, None while auto has no publisher."""
        if self.settings.scene_type != 'auto':
            return self.settings.scene_type
        name = self.node.resolve_topic_name(scene_topic)
        types = {info.topic_type for info in self.node.get_publishers_info_by_topic(name)}
        kinds = [SCENE_KINDS[t] for t in sorted(types) if t in SCENE_KINDS]
        if types and not kinds and self._due((scene_topic, 'scene_type')):
            self._log().warning(f"scene topic {name} carries {', '.join(sorted(types))}; scenes "
                                f"are {' or '.join(SCENE_KINDS)}")
        return kinds[0] if kinds else None

    def _cancel_scene_timer(self) -> None:
        if self._scene_timer is not None:
            self.node.destroy_timer(self._scene_timer)
            self._scene_timer = None

    def _without_scene(self, topic: str, outcome: str, why: str) -> str:
        """Log why a cloud goes without its scene, once per kind per log_throttle_sec."""
        if self._due((topic, 'scene', outcome)):
            total = self.stats[topic].scenes[outcome] + 1   # counted once it is estimated
            scene_topic = self._scenes.topic_of[topic]
            self._log().warning(f'{topic}: cloud answered without a scene ({outcome}, {total} so '
                                f'far): {self._resolved.get(scene_topic, scene_topic)}: {why}')
        return outcome

    def _scenes_text(self) -> str:
        names = [sub.topic_name for sub in self._scene_subs]
        names += [f'{t} once published' for t in self._waiting_scenes()]
        return f" with scenes from {', '.join(names)}" if names else ''

    # -- diagnostics --------------------------------------------------------------------------
    def _workers_text(self) -> str:
        n = self.settings.workers
        return 'answering in the node process' if n == 1 else f'{n} worker processes'

    def diagnostics(self) -> DiagnosticArray:
        """
        Make the node's statuses: its model, then one per input topic.

        Names carry the node's fully qualified name and the resolved topic, so instances in
        other namespaces differ.
        """
        fqn = self.node.get_fully_qualified_name()
        arr = DiagnosticArray()
        arr.header.stamp = self.node.get_clock().now().to_msg()
        engine = self.engine
        if engine is not None:
            problems = [self._model_problem] if self._model_problem else []
            problems += [f'worker {k} {why}' for k, why in sorted(engine.down.items())]
            values = {'model_path': engine.path, 'gallery_objects': len(engine.model.gallery_ids),
                      'categories': ', '.join(engine.model.categories),
                      'workers': self.settings.workers,
                      'worker_pids': ', '.join(str(p) for p in engine.pids() if p),
                      'worker_restarts': engine.restarts}
            arr.status.append(DiagnosticStatus(
                level=DiagnosticStatus.WARN if problems else DiagnosticStatus.OK,
                name=f'{fqn}: model', hardware_id='pcrp',
                message='; '.join(problems) or f'answering with {engine.describe()}',
                values=[KeyValue(key=k, value=str(v)) for k, v in values.items()]))
        for topic, stats in self.stats.items():
            ok, text = stats.status()
            values = stats.snapshot()
            if topic in self._scenes.topic_of:
                scene_topic = self._scenes.topic_of[topic]
                values['scene_topic'] = self._resolved.get(scene_topic, scene_topic)
            arr.status.append(DiagnosticStatus(
                level=DiagnosticStatus.OK if ok else DiagnosticStatus.WARN,
                name=f'{fqn}: {self._resolved.get(topic, topic)}', hardware_id='pcrp',
                message=text, values=[KeyValue(key=k, value=_text(k, v))
                                      for k, v in sorted(values.items())]))
        return arr

    def publish_diagnostics(self) -> None:
        if self._diag is not None:
            self._diag.publish(self.diagnostics())

    def worker_pids(self) -> list:
        engine = self.engine
        return [] if engine is None else engine.pids()


def _text(key: str, value) -> str:
    if isinstance(value, float):
        return f'{value:.3f}' if key.startswith('confidence') else f'{value:.1f}'
    return str(value)


def _or_default(value, default):
    return ros_value(default) if value is None else value


def _checked_up(value, model):
    """
    Check up_vector and return it as estimate() takes it (None for [0, 0, 0]).

    ValueError says why it cannot be used. Without a model only its shape is checked (the
    model is checked on loading).
    """
    v = np.asarray(list(value), dtype=np.float64)
    if v.shape == (3,) and not v.any():
        return None
    if model is None:
        if v.shape != (3,) or not np.isfinite(v).all():
            raise ValueError(f'up_vector {list(value)!r}: expected a finite 3-vector')
        return v / np.linalg.norm(v)
    try:
        return model.check_up(v)
    except ValueError as e:
        raise ValueError(f'up_vector {list(value)!r}: {e}') from None


def _check_model_settings(values: dict) -> None:
    """Raise ValueError unless the model settings are valid together (no model needed)."""
    query = set(QueryOptions.__dataclass_fields__)
    instance = set(InstanceOptions.__dataclass_fields__)
    QueryOptions(**{k: v for k, v in values.items() if k in query})
    InstanceOptions(**{k: v for k, v in values.items() if k in instance})
    PoseOptions(**{k: v for k, v in values.items() if k not in query | instance})
