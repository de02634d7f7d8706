"""Energy analysis of texture algorithms (Campion & Hayward, Sections III–IV), a package by
concern: :mod:`.characteristic` (the characteristic number q), :mod:`.work` (path and loop
work, curl, conservativity), :mod:`.continuity`, :mod:`.passivity` (Corollary 1, the largest
passive stiffness, the rendering limits), :mod:`.maps` (force, gain and curl on a grid) and
:mod:`._region` (the analysed region and the scale guards every region analysis applies first).

Analysis functions take an algorithm and return plain numbers or small frozen
dataclasses; they never plot.
"""

from ._region import (MAX_ANALYSIS_STIFFNESS, MAX_REGION_PERIODS, MAX_SLOPE, MIN_ANALYSIS_STIFFNESS,
                      check_analysis_scale, checked_algorithms)
from .characteristic import PAPER_Q_F, CharacteristicNumber, characteristic_number, friction_bounds, spectral_norm
from .continuity import Continuity, continuity
from .maps import MAX_MAP_POINTS, FieldMap, default_window, field_map
from .passivity import (Cutoff, Limit, PassivityCondition, max_passive_stiffness, passivity_condition,
                        rendering_cutoff, texture_limits)
from .work import (MAX_PATH_PIECES, Conservativity, conservativity, curl, curl_of_jacobian, loop_energy, paper_loop,
                   path_work, random_loops)

__all__ = [
    "Cutoff",
    "rendering_cutoff",
    "CharacteristicNumber",
    "characteristic_number",
    "friction_bounds",
    "spectral_norm",
    "path_work",
    "loop_energy",
    "paper_loop",
    "curl",
    "curl_of_jacobian",
    "FieldMap",
    "field_map",
    "default_window",
    "MAX_MAP_POINTS",
    "Continuity",
    "continuity",
    "Conservativity",
    "conservativity",
    "random_loops",
    "Limit",
    "texture_limits",
    "PassivityCondition",
    "passivity_condition",
    "max_passive_stiffness",
    "check_analysis_scale",
    "checked_algorithms",
    "MAX_ANALYSIS_STIFFNESS",
    "MIN_ANALYSIS_STIFFNESS",
    "MAX_SLOPE",
    "MAX_REGION_PERIODS",
    "MAX_PATH_PIECES",
    "PAPER_Q_F",
]
