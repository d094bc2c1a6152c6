"""The front camera's topic: frames rendered on the camera's own schedule, sent each period.

Design intent: the camera's rate (24 Hz) is not a multiple of the I/O period's, so frames are
rendered after the physics step they fall due in and held until the period's end, when they
go out with its ``/clock``, serialised by hand (:mod:`servicesim_sim.wire.image_message`);
nothing is rendered while nobody reads the camera (a frame is the costliest thing the
simulator makes). Who reads it is DDS's word (a subscription matched) while no lockstep client
is joined, and the clients' word while one is: they name the period from which they read it
(:meth:`~servicesim_sim.lockstep.server.LockstepServer.reads`), so a
seed replays with the frames a look judges.
"""

from __future__ import annotations

import numpy as np
from sensor_msgs.msg import Image

from servicesim_sim.lockstep.server import LockstepServer
from servicesim_sim.model.engine import SimEngine
from servicesim_sim.ros.publishing import Publishing, stamp
from servicesim_sim.wire.image_message import ImageBytes

CAMERA_TOPIC = "/servicebot/camera_front/image_raw"
CAMERA_FRAME = "camera_front"


class CameraTopic:
    """Renders the robot's front camera when a frame is due and publishes the frames."""

    def __init__(self, *, engine: SimEngine, rate_hz: float, publishing: Publishing,
                 lockstep: LockstepServer) -> None:
        self.engine = engine
        self.rate_hz = rate_hz
        self._send = publishing.send
        self._lockstep = lockstep
        # a period sends up to three frames at once (at most 30 a sim second): keep them all
        self.publisher = publishing.publisher(Image, CAMERA_TOPIC, 4)
        lockstep.offer(self.publisher)
        self.frames: list[tuple[float, np.ndarray]] = []
        """Frames captured and not yet sent: (sim time, pixels)."""
        self._next = 0.0
        self._encoder: ImageBytes | None = None

    def capture(self) -> None:
        """Render a frame when one is due, after a physics step, while someone reads.

        Frames fall due every 1 / rate sim s on a fixed schedule (at 24 Hz and 50 Hz physics:
        0.04 and 0.06 s apart, 24 a sim second), so the rate is kept between I/O periods;
        :meth:`publish` sends them with the period's /clock.
        """
        rate, now = self.rate_hz, self.engine.sim_time
        if rate <= 0.0 or now < self._next - 1e-9:
            return
        self._next = max(self._next + 1.0 / rate, now)
        if not self.read():
            return
        self.frames.append((now, self.engine.camera_image()))

    def read(self) -> bool:
        """Whether someone reads the camera in this period (see the module docstring)."""
        reads = self._lockstep.reads(CAMERA_TOPIC)
        return self.publisher.get_subscription_count() > 0 if reads is None else reads

    def publish(self) -> None:
        """The frames captured in this period, serialised by hand
        (:mod:`servicesim_sim.wire.image_message`)."""
        for when, pixels in self.frames:
            encoder = self._encoder
            if encoder is None or (encoder.height, encoder.width) != pixels.shape[:2]:
                encoder = self._encoder = ImageBytes(frame_id=CAMERA_FRAME,
                                                     height=pixels.shape[0],
                                                     width=pixels.shape[1])
            now = stamp(when)
            self._send(self.publisher, encoder.encode(pixels, stamp=(now.sec, now.nanosec)))
        self.frames.clear()
