"""Data-driven textures: ARMA models of a tool's vibration, indexed by speed and force.

The field's second language of haptic textures (Romano & Kuchenbecker, "Creating realistic
virtual textures from contact acceleration data", IEEE Trans. Haptics 5(2), 109–119, 2012;
Culbertson, Lopez Delgado & Kuchenbecker, "One hundred data-driven haptic texture models and
open-source methods for rendering on 3D objects", IEEE Haptics Symposium 2014, the Penn
Haptic Texture Toolkit, HaTT): a tool dragged over a real surface records its high-frequency
acceleration with its normal force and tangential speed; the signal at each steady operating
point is fitted by an ARMA model; the models sit at the vertices of a triangulation over
(speed, force), and the renderer interpolates their line spectral frequencies (LSF), variance
and gain at the current speed and force and filters white noise through the result:

    y_n = -sum_{i=1..p} a_i y_{n-i} + gain * (e_n + sum_{i=1..q} b_i e_{n-i}),  e_n ~ N(0, variance).

The synthesis runs in the C core (``hx_vibration.c``: one tick a sample, the triangle found
from the last one, a counter-based noise generator, so that a run is reproducible); this
module reads and writes model sets, fits them from recordings, and holds the NumPy oracle of
the interpolation (:meth:`ModelSet.model_at`) and the models' spectra (:meth:`ArmaModel.psd`).

Units are SI: speed in m/s, force in N, acceleration in m/s², variance in (m/s²)², frequency
in Hz. HaTT's files give speeds in mm/s; :func:`read_hatt` converts them.

A package by concern (its names are all here, ``haptex.datadriven.X``): :mod:`.lsf` (line
spectral frequencies), :mod:`.models` (one model, a set, its check), :mod:`.formats` (haptex's
JSON, HaTT's XML), :mod:`.fitting` (DFT321, the fit), :mod:`.recordings` (recordings as the rig
wrote them, the spectral difference), :mod:`.surface` (a surface from a recording, a texture as
a follower's vibration) and :mod:`.energy` (the power at a device's port).
"""


from .lsf import MAX_ORDER, poly_to_lsf, lsf_to_poly
from .models import (FORMAT, FORMAT_VERSION, MAX_MODELS, MAX_SAMPLES, G, ArmaModel, ModelSet, SetCheck, check_models)
from .formats import MAX_FILE_BYTES, read_hatt, read_models, write_hatt
from .fitting import dft321, FitReport, fit, HELD, TAPER
from .recordings import (
    RECORDING_COLUMNS, Recording, RECORDING_QUANTITIES, SPEED_FILTER, read_recording, spectral_difference)
from .surface import (
    SURFACE_BAND, MAX_SURFACE_SAMPLES, height_spectrum, surface_from, MAX_AREAL_SIDE, VIBRATION_BAND,
    MAX_FOLLOWER_SAMPLES, FollowerVibration, FOLLOWER_LINES, follower_vibration)
from .energy import VibrationEnergy, require_servo_rate, port_energy

__all__ = [
    'MAX_ORDER', 'poly_to_lsf', 'lsf_to_poly', 'FORMAT', 'FORMAT_VERSION', 'MAX_MODELS', 'MAX_SAMPLES', 'G',
    'ArmaModel', 'ModelSet', 'SetCheck', 'check_models', 'MAX_FILE_BYTES', 'read_models', 'read_hatt', 'write_hatt',
    'dft321', 'FitReport', 'fit', 'HELD', 'TAPER', 'RECORDING_COLUMNS', 'Recording', 'RECORDING_QUANTITIES',
    'SPEED_FILTER', 'read_recording', 'spectral_difference', 'SURFACE_BAND', 'MAX_SURFACE_SAMPLES',
    'height_spectrum', 'surface_from', 'MAX_AREAL_SIDE', 'VIBRATION_BAND', 'MAX_FOLLOWER_SAMPLES',
    'FollowerVibration', 'FOLLOWER_LINES', 'follower_vibration', 'VibrationEnergy', 'require_servo_rate',
    'port_energy',
]

# documented, pickled and reported as haptex.datadriven's, as before the package (numpy's set_module)
for _name in __all__:
    _obj = globals()[_name]
    if getattr(_obj, "__module__", "").startswith(__name__ + "."):
        _obj.__module__ = __name__
del _name, _obj
