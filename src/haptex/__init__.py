"""haptex: synthesis and energy analysis of haptic textures.

Implements the smooth wall W and the texture algorithms A–G of Campion & Hayward,
"On the Synthesis of Haptic Textures" (IEEE Transactions on Robotics 24(3), 527–536, 2008), their Jacobians,
characteristic numbers and loop energies. SI units throughout (m, N, s).
"""

from . import friction, operators
from ._validation import ParameterError
from .algorithms import ALGORITHMS, Algorithm, algorithm
from .friction import PreslidingState
from .analysis import (
    CharacteristicNumber,
    Conservativity,
    Continuity,
    characteristic_number,
    conservativity,
    continuity,
    curl,
    friction_bounds,
    loop_energy,
    max_passive_stiffness,
    passivity_condition,
    texture_limits,
    paper_loop,
    path_work,
    random_loops,
    spectral_norm,
)
from .closest import ClosestPoint, closest_point
from .devices import Device, critical_stiffness, five_bar_jacobian
from . import catalogue, limits
from .catalogue import device_from_file
from .limits import wall_limits
from .identification import Identification, identify
from . import objects
from .objects import object_algorithm
from .renderer import EnergyBounding, PassiveSetPosition, PassivityController, Renderer, Stabiliser
from .simulate import AxisOscillation, BatchResult, Oscillation, SimulationResult, SimulationWarning, simulate, simulate_batch
from .tables import PAPER_PARAMETERS, table_ii
from .atlas import SweepSpec, open_atlas, sweep
from .surfaces import BandLimitedNoise2D, Extruded, Grating, SampledSurface, SumOfGratings, Surface, load_texture
from .textures import BandLimitedNoise, Flat, SampledProfile, Sinusoid, SumOfSinusoids, Texture

__version__ = "0.1.0"

__all__ = [
    "ALGORITHMS",
    "BandLimitedNoise",
    "BandLimitedNoise2D",
    "Extruded",
    "Grating",
    "SampledSurface",
    "SweepSpec",
    "open_atlas",
    "sweep",
    "load_texture",
    "SumOfGratings",
    "Surface",
    "SampledProfile",
    "SimulationWarning",
    "BatchResult",
    "Device",
    "Identification",
    "identify",
    "AxisOscillation",
    "Oscillation",
    "SimulationResult",
    "critical_stiffness",
    "catalogue",
    "limits",
    "objects",
    "object_algorithm",
    "wall_limits",
    "device_from_file",
    "five_bar_jacobian",
    "operators",
    "simulate",
    "simulate_batch",
    "Algorithm",
    "CharacteristicNumber",
    "ClosestPoint",
    "Conservativity",
    "Continuity",
    "Flat",
    "PAPER_PARAMETERS",
    "ParameterError",
    "PreslidingState",
    "PassivityController",
    "EnergyBounding",
    "PassiveSetPosition",
    "Stabiliser",
    "Renderer",
    "Sinusoid",
    "SumOfSinusoids",
    "Texture",
    "algorithm",
    "characteristic_number",
    "closest_point",
    "conservativity",
    "continuity",
    "curl",
    "friction",
    "friction_bounds",
    "loop_energy",
    "max_passive_stiffness",
    "passivity_condition",
    "texture_limits",
    "paper_loop",
    "path_work",
    "random_loops",
    "spectral_norm",
    "table_ii",
]
