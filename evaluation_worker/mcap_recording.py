"""An MCAP recording of an evaluation, for Foxglove: camera frames, car pose, action, reward and status per step.

Channels (one message per simtrace row unless noted; log time = simulation time in ns, so laps line up with the
simtrace `tstamp`):

    /camera/<SENSOR>[/<i>]  foxglove.RawImage        what the network saw: the 160x120 mono8 observation
                                                     (stereo: one channel per eye, /0 = left, /1 = right)
    /camera/rgb             foxglove.CompressedImage the car camera's RGB frame, JPEG
    /lidar/LIDAR            foxglove.LaserScan       LIDAR models: the 64 clipped ranges, placed at the car in "track"
    /sensors/<SENSOR>       JSON                     sector-LIDAR models: the observation's bits
    /car/pose               foxglove.PoseInFrame     car origin and heading in frame "track" (metres, world frame)
    /car/action             JSON                     chosen action and its steering/speed
    /car/reward             JSON                     reward and progress of the step
    /car/status             JSON                     simtrace status, done, lap, resets used, pause left
    /simtrace               JSON                     the full simtrace row
    /track                  foxglove.SceneUpdate     centre line and borders as line strips (one message)
    /objects                foxglove.SceneUpdate     object avoidance / head-to-bot: each obstacle and bot car as a
                                                     cube of its drawn size at its pose, id = its name
    /objects/poses          JSON                     the same objects as numbers: name, kind, x, y, yaw, speed

Foxglove's well-known protobuf schemas are embedded; JSON channels carry a JSON Schema.
"""

from __future__ import annotations

import json
import math
from collections import Counter
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.CompressedImage_pb2 import CompressedImage
from foxglove_schemas_protobuf.CubePrimitive_pb2 import CubePrimitive
from foxglove_schemas_protobuf.LaserScan_pb2 import LaserScan
from foxglove_schemas_protobuf.LinePrimitive_pb2 import LinePrimitive
from foxglove_schemas_protobuf.Point3_pb2 import Point3
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.PoseInFrame_pb2 import PoseInFrame
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.RawImage_pb2 import RawImage
from foxglove_schemas_protobuf.SceneEntity_pb2 import SceneEntity
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3
from google.protobuf.timestamp_pb2 import Timestamp
from mcap.writer import CompressionType, Writer
from mcap_protobuf.schema import register_schema

from racer.evaluation_worker.driver import StepRecord
from racer.shared.sim.env import DeepRacerEnv
from racer.shared.sim.objects.bodies import drawn_size
from racer.shared.sim.objects.poses import ObjectKind, ObjectPose
from racer.shared.sim.sensors.lidar import MAX_ANGLE_RAD, MIN_ANGLE_RAD

FRAME_ID = "track"
JPEG_QUALITY = 85
OBJECT_COLORS = {
    ObjectKind.BOX_OBSTACLE: Color(r=0.482, g=0.38, b=0.309, a=1.0),
    ObjectKind.BOT_CAR: Color(r=0.156, g=0.156, b=0.156, a=1.0),
}

_NUMBER = {"type": "number"}
_JSON_SCHEMAS: dict[str, dict[str, Any]] = {
    "/car/action": {
        "title": "racer.Action",
        "type": "object",
        "properties": {
            "lap": {"type": "integer"},
            "step": _NUMBER,
            "action": {"description": "discrete index, or [steering, speed] in [-1, 1] for a continuous space"},
            "steering_angle_deg": _NUMBER,
            "speed_mps": _NUMBER,
        },
    },
    "/car/reward": {
        "title": "racer.Reward",
        "type": "object",
        "properties": {"lap": {"type": "integer"}, "reward": _NUMBER, "progress_pct": _NUMBER},
    },
    "/car/status": {
        "title": "racer.Status",
        "type": "object",
        "properties": {
            "lap": {"type": "integer"},
            "episode_status": {"type": "string"},
            "done": {"type": "boolean"},
            "all_wheels_on_track": {"type": "boolean"},
            "lap_resets": {"type": "integer"},
            "pause_duration_s": _NUMBER,
        },
    },
    "/simtrace": {"title": "racer.SimtraceRow", "type": "object", "description": "DeepRacer's simtrace columns"},
    "/objects/poses": {
        "title": "racer.RaceObjects",
        "type": "object",
        "description": "obstacles and bot cars where the step's observation saw them (track frame)",
        "properties": {
            "lap": {"type": "integer"},
            "objects": {
                "type": "array",
                "items": {
                    "type": "object",
                    "properties": {
                        "name": {"type": "string"},
                        "kind": {"type": "string", "enum": [kind.value for kind in ObjectKind]},
                        "x_m": _NUMBER,
                        "y_m": _NUMBER,
                        "yaw_rad": _NUMBER,
                        "speed_mps": _NUMBER,
                    },
                },
            },
        },
    },
    "/sensors": {
        "title": "racer.SensorVector",
        "type": "object",
        "properties": {"lap": {"type": "integer"}, "values": {"type": "array", "items": _NUMBER}},
    },
}


def _timestamp(time_ns: int) -> Timestamp:
    return Timestamp(seconds=time_ns // 1_000_000_000, nanos=time_ns % 1_000_000_000)


def _plain(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    return value


class McapRecorder:
    """A StepObserver streaming the recording to `path` (zstd-compressed chunks)."""

    def __init__(self, env: DeepRacerEnv, path: Path, metadata: dict[str, str] | None = None) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        self.path = path
        self._file = path.open("wb")
        self._writer = Writer(self._file, compression=CompressionType.ZSTD)
        self._writer.start(profile="", library="racer evaluation worker")
        self._channels: dict[str, int] = {}
        self._schemas: dict[str, int] = {}
        self.message_counts: Counter[str] = Counter()
        self._env = env
        self._rgb: np.ndarray | None = None
        self._objects: tuple[ObjectPose, ...] = ()
        self._track_written = False
        if metadata:
            self._writer.add_metadata("evaluation", {key: str(value) for key, value in metadata.items()})

    # ----- channels ------------------------------------------------------------------------------------------

    def _protobuf_channel(self, topic: str, message_class: Any) -> int:
        if topic not in self._channels:
            name = message_class.DESCRIPTOR.full_name
            if name not in self._schemas:
                self._schemas[name] = register_schema(self._writer, message_class)
            self._channels[topic] = self._writer.register_channel(
                topic=topic, message_encoding="protobuf", schema_id=self._schemas[name]
            )
        return self._channels[topic]

    def _json_channel(self, topic: str) -> int:
        if topic not in self._channels:
            definition = _JSON_SCHEMAS["/sensors" if topic.startswith("/sensors/") else topic]
            schema = json.dumps(definition).encode()
            schema_id = self._writer.register_schema(name=definition["title"], encoding="jsonschema", data=schema)
            self._channels[topic] = self._writer.register_channel(
                topic=topic, message_encoding="json", schema_id=schema_id
            )
        return self._channels[topic]

    def _write(self, topic: str, channel_id: int, time_ns: int, data: bytes) -> None:
        self._writer.add_message(
            channel_id=channel_id,
            log_time=time_ns,
            publish_time=time_ns,
            data=data,
            sequence=self.message_counts[topic],
        )
        self.message_counts[topic] += 1

    def _write_protobuf(self, topic: str, message: Any, time_ns: int) -> None:
        self._write(topic, self._protobuf_channel(topic, type(message)), time_ns, message.SerializeToString())

    def _write_json(self, topic: str, payload: dict[str, Any], time_ns: int) -> None:
        self._write(topic, self._json_channel(topic), time_ns, json.dumps(payload, default=_plain).encode())

    # ----- observer ------------------------------------------------------------------------------------------

    def before_step(self, env: DeepRacerEnv) -> None:
        self._rgb = env.render() if env.render_mode == "rgb_array" else None
        self._objects = tuple(env.object_poses)

    def on_step(self, record: StepRecord) -> None:
        row = record.row
        time_ns = int(round(float(row["tstamp"]) * 1e9))
        stamp = _timestamp(time_ns)
        if not self._track_written:
            self._write_protobuf("/track", self._track_scene(stamp), time_ns)
            self._track_written = True
        car = record.car
        half_yaw = car.yaw_rad / 2.0
        car_pose = Pose(
            position=Vector3(x=car.origin_x_m, y=car.origin_y_m, z=0.0),
            orientation=Quaternion(x=0.0, y=0.0, z=math.sin(half_yaw), w=math.cos(half_yaw)),
        )
        for sensor, value in record.observation.items():
            image = np.asarray(value)
            if image.ndim == 1:
                self._write_vector(sensor, image, record.lap_index, car_pose, stamp, time_ns)
                continue
            for index in range(image.shape[2]):
                topic = f"/camera/{sensor}" if image.shape[2] == 1 else f"/camera/{sensor}/{index}"
                plane = np.ascontiguousarray(image[:, :, index])
                self._write_protobuf(
                    topic,
                    RawImage(
                        timestamp=stamp,
                        frame_id="camera",
                        width=plane.shape[1],
                        height=plane.shape[0],
                        encoding="mono8",
                        step=plane.shape[1],
                        data=plane.tobytes(),
                    ),
                    time_ns,
                )
        if self._rgb is not None:
            ok, jpeg = cv2.imencode(
                ".jpg", cv2.cvtColor(self._rgb, cv2.COLOR_RGB2BGR), [cv2.IMWRITE_JPEG_QUALITY, JPEG_QUALITY]
            )
            if ok:
                self._write_protobuf(
                    "/camera/rgb",
                    CompressedImage(timestamp=stamp, frame_id="camera", data=jpeg.tobytes(), format="jpeg"),
                    time_ns,
                )
            self._rgb = None
        self._write_protobuf("/car/pose", PoseInFrame(timestamp=stamp, frame_id=FRAME_ID, pose=car_pose), time_ns)
        lap = record.lap_index
        self._write_json(
            "/car/action",
            {
                "lap": lap,
                "step": row["steps"],
                "action": _plain(record.action),
                "steering_angle_deg": row["steer"],
                "speed_mps": row["throttle"],
            },
            time_ns,
        )
        self._write_json("/car/reward", {"lap": lap, "reward": record.reward, "progress_pct": row["progress"]}, time_ns)
        self._write_json(
            "/car/status",
            {
                "lap": lap,
                "episode_status": row["episode_status"],
                "done": bool(row["done"]),
                "all_wheels_on_track": bool(row["all_wheels_on_track"]),
                "lap_resets": record.lap_resets,
                "pause_duration_s": row["pause_duration"],
            },
            time_ns,
        )
        self._write_json("/simtrace", {key: _plain(value) for key, value in row.items()}, time_ns)
        if self._objects:
            self.write_objects(self._objects, lap, time_ns)

    def write_objects(self, objects: Sequence[ObjectPose], lap: int, time_ns: int) -> None:
        """The objects of one step: cubes for Foxglove's 3D panel and their poses as numbers."""
        stamp = _timestamp(time_ns)
        entities = []
        for obj in objects:
            length_m, width_m, height_m = drawn_size(obj.kind)
            half_yaw = obj.yaw_rad / 2.0
            cube = CubePrimitive(
                pose=Pose(
                    position=Vector3(x=obj.x_m, y=obj.y_m, z=height_m / 2.0),
                    orientation=Quaternion(x=0.0, y=0.0, z=math.sin(half_yaw), w=math.cos(half_yaw)),
                ),
                size=Vector3(x=length_m, y=width_m, z=height_m),
                color=OBJECT_COLORS[obj.kind],
            )
            entities.append(
                SceneEntity(
                    timestamp=stamp, frame_id=FRAME_ID, id=f"objects/{obj.name}", frame_locked=True, cubes=[cube]
                )
            )
        self._write_protobuf("/objects", SceneUpdate(entities=entities), time_ns)
        poses = [
            {
                "name": obj.name,
                "kind": obj.kind.value,
                "x_m": obj.x_m,
                "y_m": obj.y_m,
                "yaw_rad": obj.yaw_rad,
                "speed_mps": obj.speed_mps,
            }
            for obj in objects
        ]
        self._write_json("/objects/poses", {"lap": lap, "objects": poses}, time_ns)

    def _write_vector(
        self, sensor: str, values: np.ndarray, lap: int, car_pose: Pose, stamp: Timestamp, time_ns: int
    ) -> None:
        if sensor == "LIDAR":
            self._write_protobuf(
                "/lidar/LIDAR",
                LaserScan(
                    timestamp=stamp,
                    frame_id=FRAME_ID,
                    pose=car_pose,
                    start_angle=MIN_ANGLE_RAD,
                    end_angle=MAX_ANGLE_RAD,
                    ranges=[float(v) for v in values],
                ),
                time_ns,
            )
        else:
            self._write_json(f"/sensors/{sensor}", {"lap": lap, "values": [float(v) for v in values]}, time_ns)

    def _track_scene(self, stamp: Timestamp) -> SceneUpdate:
        track = self._env.base_track
        lines = []
        for points, color, thickness in (
            (track.center_line, Color(r=1.0, g=0.8, b=0.0, a=1.0), 0.02),
            (track.inner_border, Color(r=1.0, g=1.0, b=1.0, a=1.0), 0.05),
            (track.outer_border, Color(r=1.0, g=1.0, b=1.0, a=1.0), 0.05),
        ):
            lines.append(
                LinePrimitive(
                    type=LinePrimitive.Type.LINE_STRIP,
                    thickness=thickness,
                    scale_invariant=False,
                    color=color,
                    pose=Pose(
                        position=Vector3(x=0.0, y=0.0, z=0.0), orientation=Quaternion(x=0.0, y=0.0, z=0.0, w=1.0)
                    ),
                    points=[Point3(x=float(x), y=float(y), z=0.0) for x, y in points],
                )
            )
        entity = SceneEntity(
            timestamp=stamp, frame_id=FRAME_ID, id=f"track/{track.name}", frame_locked=True, lines=lines
        )
        return SceneUpdate(entities=[entity])

    def close(self) -> None:
        if self._file.closed:
            return
        self._writer.finish()
        self._file.close()
