# Type stubs of fringe.evaluate (VDI/VDE 2634-2 figures); results are dicts with the keys of
# `fringe evaluate --json` plus "report".
from typing import Any, Dict, Optional, Union

import numpy.typing as npt

from . import PointCloud, VdiOptions

Points = Union[npt.ArrayLike, PointCloud]  # (N, 3) or (H, W, 3) with NaN rows dropped

def sphere(points: Points, diameter_mm: float, options: Optional[VdiOptions] = None, **fields: Any) -> Dict[str, Any]: ...
def ballbar(
    points: Points, diameter_mm: float, distance_mm: float, options: Optional[VdiOptions] = None, **fields: Any
) -> Dict[str, Any]: ...
def plane(points: Points, options: Optional[VdiOptions] = None, **fields: Any) -> Dict[str, Any]: ...
