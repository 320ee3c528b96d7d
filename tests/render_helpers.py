"""Small helpers shared by the render tests: exact camera rays and ray-plane hits, cancellation, Ctrl-C."""
import _thread
import signal
import threading

import numpy as np

import pyrt


def top_down_scene(size=64, height=3.0, fov=60.0, albedo=0.6, plane=4.0):
    """A Lambertian square plane at y = 0 seen straight down from (0, height, 0), pixel-centre rays."""
    cam = pyrt.Camera(position=(0, height, 0), target=(0, 0, 0), up=(0, 0, -1), fov=fov, width=size, height=size,
                      spp=1, jitter=False)
    scene = pyrt.Scene(cam)
    scene.add_plane((0, 0, 0), plane, pyrt.Lambert(albedo=albedo), name="floor")
    return scene


def pixel_centre_hits_on_plane_y0(cam):
    """Exact hit points of the pixel-centre rays with the plane y = 0 -> (H, W, 3)."""
    ys, xs = np.mgrid[0:cam.height, 0:cam.width]
    d = cam.directions(xs.ravel() + 0.5, ys.ravel() + 0.5)
    t = -cam.position[1] / d[:, 1]
    return (cam.position + t[:, None] * d).reshape(cam.height, cam.width, 3)


class CancelAfter(threading.Event):
    """An event that reports itself set from its ``k + 1``-th check on (a render checks once per chunk, in order
    with ``threads=1``; the previewer's batch before each asset and each view)."""

    def __init__(self, k):
        super().__init__()
        self.k, self.checks = k, 0

    def is_set(self):
        self.checks += 1
        return self.checks > self.k or super().is_set()


class CtrlC:
    """Ctrl-C for a render in the main thread: ``with CtrlC(after): render(...)`` interrupts the main thread after
    ``after`` seconds and again every ``again`` seconds until the block ends, as a user would press it again.

    One interrupt is what the render must react to. The repeats make the tests that use it independent of when the
    first one lands: twice in CI's first run of a fresh clone (a machine busy with other work), a single
    interrupt at 0.3 / 0.5 s was not seen and the render ran to its end; it could not be reproduced in later
    runs or under load. Python's own SIGINT handler is installed for the block (the previous one restored after).
    """

    def __init__(self, after, again=0.25):
        self.after, self.again = after, again
        self._done = threading.Event()
        self.sent = 0

    def _run(self):
        wait = self.after
        while not self._done.wait(wait):
            self.sent += 1
            _thread.interrupt_main()
            wait = self.again

    def __enter__(self):
        self._previous = signal.signal(signal.SIGINT, signal.default_int_handler)
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc):
        self._done.set()
        self._thread.join()
        signal.signal(signal.SIGINT, self._previous)
        return False
