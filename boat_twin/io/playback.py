"""A recorded trial as the time-ordered ROS 2 messages a live boat would publish: what the ``bag_player`` node
plays. Any trial the readers accept (rosbag2, MCAP, ROS 1 bag, MAVLink log with calibration, CSV with mapping)
goes through :func:`~boat_twin.io.samples.trial_samples` (commands on change and every second, sensors
where the trial has them) and the package's message builders (:mod:`boat_twin.io.messages`), on the topics of
the design's table, stamped ``epoch_s`` + trial time."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np

from boat_twin.config import TwinConfig
from boat_twin.frames import quaternion_xyzw
from boat_twin.io import messages
from boat_twin.io.roles import COMMAND_ROLES
from boat_twin.io.samples import trial_samples
from boat_twin.io.trial import Trial
from boat_twin.units import STANDARD_GRAVITY_MPS2

SENSOR_TOPICS = (messages.TOPIC_GNSS_FIX, messages.TOPIC_GNSS_VEL, messages.TOPIC_IMU_DATA, messages.TOPIC_WIND)
"""The sensor and measured-input topics a trial is played on (the wind where the trial measured it)."""
NOT_PROVIDED = np.array([-1.0] + [0.0] * 8)
"""REP-145: a covariance whose element 0 is −1 marks the field as not provided."""
NOT_PROVIDED.flags.writeable = False


def playback_topics(config: TwinConfig) -> dict[str, str]:
    """Topic → message type of everything :func:`playback_messages` may publish under ``config``: the commands on
    its boat's actuator topics (:func:`~boat_twin.io.messages.command_topics`: the boat file's per-name
    ``thrusters/<name>/...`` and ``rudders/<name>/angle``, else the default layout's), the sensors, the wind."""
    topics = list(messages.command_topics(config.vessel.propulsion).values()) + list(SENSOR_TOPICS)
    return {topic: messages.topic_type(topic) for topic in topics}


def playback_messages(trial: Trial, config: TwinConfig, epoch_s: float = 0.0
                      ) -> Iterator[tuple[str, int, messages.Message]]:
    """(topic, stamp ns, message) of ``trial`` in time order; covariances are the sensors' of ``config``
    (what the recording's drivers stated is not kept in a Trial); commands on ``config``'s boat's actuator
    topics (:func:`playback_topics`; a command the boat has no actuator for is not played)."""
    command_topic = messages.command_topics(config.vessel.propulsion)
    g, u = config.gnss, config.um7
    position_cov = messages.diagonal_covariance([g.horizontal_stdev_m**2, g.horizontal_stdev_m**2,
                                                 g.vertical_stdev_m**2])
    orientation_cov = messages.diagonal_covariance([u.roll_pitch_stdev_rad**2] * 2 + [u.yaw_stdev_rad**2])
    gyro_cov = messages.diagonal_covariance([u.gyro_stdev_radps**2] * 3)
    accel_cov = messages.diagonal_covariance([u.accel_stdev_mps2**2] * 3)
    for kind, t_s, values in trial_samples(trial):
        stamp_ns = int(round((epoch_s + t_s) * 1e9))
        if kind in COMMAND_ROLES:
            if kind in command_topic:
                yield command_topic[kind], stamp_ns, messages.float64(values[0])
        elif kind == "gnss_fix":
            yield messages.TOPIC_GNSS_FIX, stamp_ns, messages.navsatfix(
                messages.header(stamp_ns, messages.FRAME_GNSS), values[0], values[1], values[2], position_cov)
        elif kind == "wind":
            yield messages.TOPIC_WIND, stamp_ns, messages.vector3_stamped(
                messages.header(stamp_ns, messages.FRAME_MAP), (values[0], values[1], 0.0))
        elif kind == "gnss_vel":
            yield messages.TOPIC_GNSS_VEL, stamp_ns, messages.twist_stamped(
                messages.header(stamp_ns, messages.FRAME_GNSS), (values[0], values[1], 0.0))
        else:
            yaw, rate, ax, ay = values
            known = math.isfinite(yaw)
            q = quaternion_xyzw(np.zeros(1), np.zeros(1), np.array([yaw if known else 0.0]))[0].tolist()
            accel_known = math.isfinite(ax) and math.isfinite(ay)
            yield messages.TOPIC_IMU_DATA, stamp_ns, messages.imu(
                messages.header(stamp_ns, messages.FRAME_IMU), q, (0.0, 0.0, rate),
                (ax, ay, STANDARD_GRAVITY_MPS2) if accel_known else (0.0, 0.0, 0.0),
                orientation_cov if known else NOT_PROVIDED, gyro_cov, accel_cov if accel_known else NOT_PROVIDED)
