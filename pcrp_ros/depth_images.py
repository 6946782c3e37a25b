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
A depth camera's depth image (sensor_msgs/Image) and its CameraInfo, read as a DepthImage.

What depth drivers publish by default (/camera/depth/image_rect_raw: 16UC1 millimetres, or 32FC1
metres, with camera_info beside it); a point cloud of the same frame is often switched off and
is four to eight times the bytes. Works on rclpy and rosbags messages alike (only field names are
read). Anything unreadable raises CloudFormatError with a reason: bad_encoding, bad_layout,
truncated_data, no_camera_info, camera_info_mismatch.
"""
from __future__ import annotations

import numpy as np
from pcrp_core import DepthImage
from pcrp_ros.conversions import CloudFormatError, data_bytes

# encoding -> (numpy type, metres per unit); zero means no measurement in either
ENCODINGS = {'16UC1': ('u2', 0.001), 'mono16': ('u2', 0.001), '32FC1': ('f4', 1.0)}


def camera_info_topic(image_topic: str) -> str:
    """Return the CameraInfo topic beside an image topic, as image_transport pairs them."""
    namespace, _, _ = image_topic.rpartition('/')
    return f'{namespace}/camera_info' if namespace else 'camera_info'


def depth_metres(msg) -> np.ndarray:
    """
    Return a depth image's depth in metres, (height, width) float32.

    As sent: 0 or NaN where none, which DepthImage reads as no measurement (it cleans every image
    it is given, so a frame is not passed over twice here).
    """
    if msg.encoding not in ENCODINGS:
        raise CloudFormatError('bad_encoding', f'depth image encoded {msg.encoding!r}; expected '
                                               f"one of {', '.join(ENCODINGS)}")
    code, scale = ENCODINGS[msg.encoding]
    dtype = np.dtype(('>' if msg.is_bigendian else '<') + code)
    height, width, step = int(msg.height), int(msg.width), int(msg.step)
    if step < width * dtype.itemsize:
        raise CloudFormatError('bad_layout', f'step {step} is less than width {width} x '
                                             f'{dtype.itemsize} bytes')
    buf = data_bytes(msg.data)
    if len(buf) < step * height:
        raise CloudFormatError('truncated_data', f'data has {len(buf)} bytes, step {step} x '
                                                 f'height {height} needs {step * height}')
    raw = np.ndarray((height, width), dtype=dtype, buffer=buf, strides=(step, dtype.itemsize))
    return raw.astype(np.float32) * np.float32(scale)


def depth_image(msg, info) -> DepthImage:
    """Return the DepthImage of a depth image msg taken with the camera info describes."""
    if info is None:
        raise CloudFormatError('no_camera_info', 'no CameraInfo has come for this depth image')
    if info.header.frame_id != msg.header.frame_id:
        raise CloudFormatError('camera_info_mismatch', f'CameraInfo in frame '
                                                       f'{info.header.frame_id!r}, the image in '
                                                       f'{msg.header.frame_id!r}')
    focal, centre, size = intrinsics(info)
    if size is not None and size != (int(msg.width), int(msg.height)):
        raise CloudFormatError('camera_info_mismatch', f'CameraInfo of {size[0]} x {size[1]} '
                                                       f'(binning and region of interest '
                                                       f'applied), the image {msg.width} x '
                                                       f'{msg.height}')
    return DepthImage(depth_metres(msg), focal, centre)


def intrinsics(info) -> tuple[np.ndarray, np.ndarray, tuple[int, int] | None]:
    """
    Return (focal, centre) in pixels of the image info describes, and its size (None: unset).

    Read as ROS's image_geometry reads them for a rectified image (what depth_image_proc turns
    into clouds): the projection matrix P, which is the rectified image's, not K, which is the raw
    one's (they differ wherever the lens distorts); K only where P is unset. Then moved by the
    region of interest and divided by the binning, as a driver that crops or bins its image says.
    """
    p = np.asarray(info.p, dtype=np.float64).reshape(-1)
    k = np.asarray(info.k, dtype=np.float64).reshape(-1)
    if len(p) == 12 and _focal_lengths(p[0], p[5]):
        fx, fy, cx, cy = p[0], p[5], p[2], p[6]
    elif len(k) == 9 and _focal_lengths(k[0], k[4]):
        fx, fy, cx, cy = k[0], k[4], k[2], k[5]
    else:
        raise CloudFormatError('camera_info_mismatch', 'CameraInfo has no focal lengths in P or K')
    bx, by = max(1, int(info.binning_x)), max(1, int(info.binning_y))
    roi = info.roi
    width, height = int(info.width), int(info.height)
    if int(roi.width) > 0 and int(roi.height) > 0:
        cx, cy = cx - int(roi.x_offset), cy - int(roi.y_offset)
        width, height = int(roi.width), int(roi.height)
    size = None if (width, height) == (0, 0) else (width // bx, height // by)
    return np.array([fx / bx, fy / by]), np.array([cx / bx, cy / by]), size


def _focal_lengths(fx: float, fy: float) -> bool:
    return bool(np.isfinite(fx) and np.isfinite(fy) and fx > 0 and fy > 0)
