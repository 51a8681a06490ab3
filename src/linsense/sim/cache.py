"""A bounded, thread-safe cache of the pure work of a build (motor files, designs, tables).

A sweep builds thousands of scenarios of a few motors: loading and checking a motor file, the
design and the controller's tables are pure functions of the motor and a few numbers, kept here
(bounded, thread-safe: sweeps run in worker threads). Cached values are never mutated.
"""

from __future__ import annotations

import hashlib
import threading
from collections import OrderedDict

import numpy as np

from linsense.model.motor import Motor

_CACHE: OrderedDict = OrderedDict()
_CACHE_LOCK = threading.Lock()
_CACHE_SIZE = 256


def memo(key: tuple, fn):
    """``fn()``, computed once per ``key`` while the key stays among the last cached.

    Parameters
    ----------
    key : tuple
        Hashable key of the value.
    fn : callable
        ``fn()`` computes it.

    Returns
    -------
    object
        The cached or computed value.
    """
    with _CACHE_LOCK:
        if key in _CACHE:
            _CACHE.move_to_end(key)
            return _CACHE[key]
    value = fn()
    with _CACHE_LOCK:
        _CACHE[key] = value
        while len(_CACHE) > _CACHE_SIZE:
            _CACHE.popitem(last=False)
    return value


def motor_key(motor: Motor) -> str:
    """A fingerprint of everything that defines ``motor`` (parameters and inductance series).

    Parameters
    ----------
    motor : Motor
        The motor.

    Returns
    -------
    str
        The fingerprint.
    """
    hit = memo(("key", id(motor)), lambda: (motor, _fingerprint(motor)))
    if hit[0] is motor:  # (the cache keeps the motor alive, so its id is not reused meanwhile)
        return hit[1]
    return _fingerprint(motor)


def _fingerprint(motor: Motor) -> str:
    h = hashlib.sha256(repr((motor.name, motor.R_s, motor.pole_pitch, motor.force_constant, motor.mass,
                             motor.friction, motor.pm_harmonics)).encode())
    h.update(np.ascontiguousarray(motor.inductance.a).tobytes())
    h.update(np.ascontiguousarray(motor.inductance.b).tobytes())
    if motor.saturation is not None:
        h.update(repr(motor.saturation.key()).encode())
    if not motor.pm_phases.balanced:  # (a balanced motor keeps the fingerprint it had before)
        h.update(repr(motor.pm_phases).encode())
    return h.hexdigest()
