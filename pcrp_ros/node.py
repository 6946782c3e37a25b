"""pcrp_node: segmented object clouds in; gallery ID, pose and the aligned model out.

Per input topic T: T/pose (PoseStamped), T/gallery_id (String), T/aligned_model (PointCloud2)
and, where vision_msgs is installed, T/detections (Detection3DArray); all carry the input's
header unchanged. Clouds are answered newest-first by one worker thread, so a slow model drops
stale clouds (counted) instead of queueing them. Clouds are checked on arrival, so every
unusable one is refused and counted under its reason however busy the worker is.
"""
from __future__ import annotations

import faulthandler
import signal
import sys
import threading
import time

import numpy as np
import rclpy
from diagnostic_msgs.msg import DiagnosticArray, DiagnosticStatus, KeyValue
from geometry_msgs.msg import PoseStamped
from rcl_interfaces.msg import SetParametersResult
from rclpy.exceptions import NameValidationException, ParameterException
from rclpy.executors import ExternalShutdownException, SingleThreadedExecutor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy, HistoryPolicy, qos_profile_sensor_data
from sensor_msgs.msg import PointCloud2
from std_msgs.msg import String

from pcrp_core import InvalidCloud, ModelError, PCRP
from pcrp_ros.conversions import CloudFormatError, aligned_points, detections_msg, pointcloud2_to_xyz, pose_stamped, xyz_to_pointcloud2
from pcrp_ros.parameters import MODEL_SETTINGS, NodeSettings, descriptor, parameters, ros_value
from pcrp_ros.stats import StreamStats

class PcrpNode(Node):
    def __init__(self, model: PCRP | None = None, node_name: str = "pcrp_node", **kwargs):
        super().__init__(node_name, **kwargs)
        for spec in parameters():
            self.declare_parameter(spec["name"], ros_value(spec["default"]), descriptor(spec))
        p = {spec["name"]: self.get_parameter(spec["name"]).value for spec in parameters()}
        NodeSettings(**{k: p[k] for k in NodeSettings.__dataclass_fields__})   # ValueError saying which is wrong
        self.model = model if model is not None else PCRP.load(p["model_path"] or None)
        self.model.set_params(**{k: p[k] for k in MODEL_SETTINGS})
        self._up = self._checked_up(p["up_vector"])
        self.add_on_set_parameters_callback(self._on_set_parameters)

        qos = QoSProfile(history=HistoryPolicy.KEEP_LAST, depth=p["qos_depth"],
                         reliability=ReliabilityPolicy.BEST_EFFORT if p["qos_reliability"] == "best_effort"
                         else ReliabilityPolicy.RELIABLE, durability=qos_profile_sensor_data.durability)
        out_qos = QoSProfile(depth=10)   # reliable: a planner must not miss a pose
        self.stats: dict[str, StreamStats] = {}
        self._pubs: dict[str, dict] = {}
        self._slots: dict[str, tuple] = {}
        self._cv = threading.Condition()
        self._running = True
        self._last_log: dict[tuple[str, str], float] = {}
        for topic in p["input_topics"]:
            sub = self.create_subscription(PointCloud2, topic, lambda msg, t=topic: self._on_cloud(t, msg), qos)
            resolved = sub.topic_name
            pubs = {"pose": self.create_publisher(PoseStamped, f"{resolved}/pose", out_qos),
                    "gallery_id": self.create_publisher(String, f"{resolved}/gallery_id", out_qos),
                    "aligned_model": self.create_publisher(PointCloud2, f"{resolved}/aligned_model", out_qos)}
            try:
                from vision_msgs.msg import Detection3DArray
                pubs["detections"] = self.create_publisher(Detection3DArray, f"{resolved}/detections", out_qos)
            except ImportError:
                pass
            self._pubs[topic] = pubs
            self.stats[topic] = StreamStats()
        self._diag = self.create_publisher(DiagnosticArray, "/diagnostics", 10)
        self.create_timer(1.0, self._publish_diagnostics)
        self._worker = threading.Thread(target=self._work, name="pcrp_worker", daemon=True)
        self._worker.start()
        self.get_logger().info(f"pcrp_node: {len(self.model.gallery_ids)} gallery objects "
                               f"({', '.join(self.model.categories)}), listening on "
                               f"{', '.join(s.topic_name for s in self.subscriptions)}")

    # -- parameters ---------------------------------------------------------------------------------
    def _checked_up(self, value):
        """up_vector as estimate() takes it (None for [0, 0, 0]); ValueError saying why it cannot be used."""
        v = np.asarray(list(value), dtype=np.float64)
        if v.shape == (3,) and not v.any():
            return None
        try:
            return self.model.check_up(v)
        except ValueError as e:
            raise ValueError(f"up_vector {list(value)!r}: {e}") from None

    def _on_set_parameters(self, params) -> SetParametersResult:
        changes = {p.name: p.value for p in params if p.name in MODEL_SETTINGS}
        up = [p.value for p in params if p.name == "up_vector"]
        try:
            new_up = self._checked_up(up[0]) if up else self._up
            self.model.set_params(**changes)   # validates every value before setting any
        except ValueError as e:
            return SetParametersResult(successful=False, reason=str(e))
        self._up = new_up
        return SetParametersResult(successful=True)

    # -- receiving ------------------------------------------------------------------------------------
    def _on_cloud(self, topic: str, msg: PointCloud2) -> None:
        """Refuse unreadable clouds at once (cheap) so every bad cloud is counted under its reason,
        however busy the worker is; queue only usable ones, newest replacing any still waiting."""
        received = time.monotonic()
        self.stats[topic].count("received")
        try:
            points = self.model.prepare(pointcloud2_to_xyz(msg, finite_only=False))
        except (CloudFormatError, InvalidCloud) as e:
            self._reject(topic, e.reason, str(e))
            return
        except Exception as e:   # nothing one message holds may take the subscription down
            self._reject(topic, "internal_error", f"{type(e).__name__}: {e}")
            return
        with self._cv:
            if topic in self._slots:
                self.stats[topic].count("dropped_stale")
            self._slots[topic] = (msg.header, points, received)
            self._cv.notify()

    def _work(self) -> None:
        while True:
            with self._cv:
                self._cv.wait_for(lambda: self._slots or not self._running)
                if not self._running:
                    return
                topic = next(iter(self._slots))     # oldest-waiting topic first: fair across topics
                header, points, received = self._slots.pop(topic)
            try:
                self._answer(topic, header, points, received)
            except Exception as e:   # the stream must survive anything one cloud does
                self._reject(topic, "internal_error", f"{type(e).__name__}: {e}")

    def _reject(self, topic: str, reason: str, message: str) -> None:
        """Count, and log once per topic and reason per log_throttle_sec (rclpy's own throttle is
        per call site, so one noisy reason would hide every other)."""
        self.stats[topic].count("rejected", reason)
        now = time.monotonic()
        key = (topic, reason)
        if now - self._last_log.get(key, -np.inf) >= float(self.get_parameter("log_throttle_sec").value):
            self._last_log[key] = now
            total = self.stats[topic].rejections[reason]
            self.get_logger().warn(f"{topic}: cloud rejected ({reason}, {total} so far): {message}")

    def _answer(self, topic: str, header, points: np.ndarray, received: float) -> None:
        viewpoint = np.zeros(3) if self.get_parameter("sensor_at_origin").value else None
        try:
            result = self.model.estimate(points, viewpoint=viewpoint, up=self._up)
        except InvalidCloud as e:
            self._reject(topic, e.reason, str(e))
            return
        if result.rejected:
            self._reject(topic, "low_confidence", result.reason)
            return
        pubs = self._pubs[topic]
        pubs["pose"].publish(pose_stamped(result, header))
        pubs["gallery_id"].publish(String(data=result.gallery_id))
        if self.get_parameter("publish_aligned_model").value:
            cloud = aligned_points(result, self.model.gallery_cloud(result.gallery_id))
            pubs["aligned_model"].publish(xyz_to_pointcloud2(cloud, header))
        if "detections" in pubs:
            det = detections_msg(result, header)
            if det is not None:
                pubs["detections"].publish(det)
        stamp = header.stamp.sec + 1e-9 * header.stamp.nanosec
        now = self.get_clock().now().nanoseconds * 1e-9
        self.stats[topic].timing(time.monotonic() - received, now - stamp)
        self.stats[topic].count("answered")

    # -- diagnostics ----------------------------------------------------------------------------------
    def _publish_diagnostics(self) -> None:
        arr = DiagnosticArray()
        arr.header.stamp = self.get_clock().now().to_msg()
        for topic, stats in self.stats.items():
            snap = stats.snapshot()
            level = DiagnosticStatus.OK if snap.get("answered", 0) or not snap.get("received", 0) else DiagnosticStatus.WARN
            arr.status.append(DiagnosticStatus(
                level=level, name=f"{self.get_name()}: {topic}", hardware_id="pcrp",
                message=f"{snap.get('answered', 0)} answered of {snap.get('received', 0)}",
                values=[KeyValue(key=k, value=f"{v:.1f}" if isinstance(v, float) else str(v)) for k, v in sorted(snap.items())]))
        self._diag.publish(arr)

    def destroy_node(self):
        with self._cv:
            self._running = False
            self._cv.notify_all()
        self._worker.join(timeout=5.0)
        return super().destroy_node()


def main(args=None) -> int:
    # a crash inside DDS or Open3D prints the Python stack of every thread, and `kill -USR1 <pid>`
    # prints them on demand (what a stuck node is doing), instead of dying or hanging silently
    faulthandler.enable(all_threads=True)
    if hasattr(signal, "SIGUSR1"):
        faulthandler.register(signal.SIGUSR1, all_threads=True)
    rclpy.init(args=args)
    # The executor exists before the node says it is listening: a Ctrl-C that lands while an
    # executor is being built leaves a half-made object whose __del__ prints a traceback.
    executor = SingleThreadedExecutor()
    node = None
    try:
        node = PcrpNode()
        executor.add_node(node)
        executor.spin()
    except (ModelError, ValueError, ParameterException, NameValidationException) as e:
        # a broken model or a mistyped parameter or topic in the launch configuration: one line
        print(f"pcrp_node: error: {e}", file=sys.stderr)
        return 1
    except (KeyboardInterrupt, ExternalShutdownException):
        pass
    finally:
        executor.shutdown()
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
