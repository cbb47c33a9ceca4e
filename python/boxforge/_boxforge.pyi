"""The extension module (Rust, PyO3); use the functions of ``boxforge`` instead."""

from typing import List, Optional, Tuple

import numpy as np
import numpy.typing as npt

__version__: str

ZYX = Tuple[int, int, int]

def report_json(spec: str) -> str: ...
def shader(spec: str, layout: str = "embedded") -> Tuple[str, str]: ...
def lattice_of(spec: str) -> str: ...
def matched_lattice(lattice: str, shape: ZYX) -> Tuple[ZYX, float]: ...
def resample(
    a: npt.NDArray[np.float32],
    lattice: str,
    origin: ZYX = (0, 0, 0),
    shape: Optional[ZYX] = None,
    out_origin: ZYX = (0, 0, 0),
    out_shape: Optional[ZYX] = None,
) -> npt.NDArray[np.float32]: ...
def prefilter(
    a: npt.NDArray[np.float32], spec: str, origin: ZYX = (0, 0, 0), shape: Optional[ZYX] = None
) -> npt.NDArray[np.float32]: ...
def prefilter_reach(spec: str) -> ZYX: ...
def spline_eval(
    spec: str, points: npt.NDArray[np.float64], samples: npt.NDArray[np.float32], order: int
) -> Tuple[npt.NDArray[np.float64], npt.NDArray[np.float64], npt.NDArray[np.float64]]: ...
def render_frame(
    samples: Optional[npt.NDArray[np.float32]],
    spec: str,
    mode: str = "iso",
    iso: float = 0.5,
    conversion: str = "subset",
    size: int = 512,
    azimuth: float = 30.0,
    elevation: float = 25.0,
    perspective: bool = False,
    layout: str = "embedded",
    tf: Optional[str] = None,
    preintegrate: bool = True,
    gpu_budget: Optional[str] = None,
    brick: Optional[int] = None,
    store: Optional[str] = None,
    adapter: Optional[str] = None,
) -> npt.NDArray[np.uint8]: ...
def bounds(
    samples: npt.NDArray[np.float32], spec: str, brick: int = 32, adapter: Optional[str] = None
) -> npt.NDArray[np.float32]: ...
def open_level(
    path: str, level: int = 0, channel: int = 0, time: int = 0
) -> Tuple[npt.NDArray[np.float32], str, Tuple[float, float, float], Optional[str], Optional[str]]: ...
def write_store(
    a: npt.NDArray[np.float32],
    path: str,
    lattice: Optional[str] = None,
    prefilter: Optional[str] = None,
    chunk: int = 64,
    shard: Optional[int] = None,
    levels: Optional[int] = None,
    reduction: str = "box",
    dtype: Optional[str] = None,
    spacing: Tuple[float, float, float] = (1.0, 1.0, 1.0),
    unit: Optional[str] = None,
) -> List[ZYX]: ...
def reduce(
    a: npt.NDArray[np.float32],
    reduction: str,
    origin: ZYX,
    shape: ZYX,
    out_origin: ZYX,
    out_shape: ZYX,
) -> npt.NDArray[np.float32]: ...

class StorePlan:
    """A store ``boxforge convert`` would write, written unit by unit by any number of processes."""

    def __init__(
        self,
        path: str,
        shape: ZYX,
        lattice: Optional[str] = None,
        prefilter: Optional[str] = None,
        chunk: int = 64,
        shard: Optional[int] = None,
        levels: Optional[int] = None,
        reduction: str = "box",
        dtype: Optional[str] = None,
        spacing: Tuple[float, float, float] = (1.0, 1.0, 1.0),
        unit: Optional[str] = None,
    ) -> None: ...
    @property
    def cartesian_levels(self) -> List[ZYX]: ...
    @property
    def levels(self) -> List[ZYX]: ...
    @property
    def lattice(self) -> Optional[str]: ...
    @property
    def block(self) -> ZYX: ...
    @property
    def reduction(self) -> str: ...
    @property
    def cartesian_block(self) -> ZYX: ...
    def unit_count(self, level: int, cartesian: bool = False) -> int: ...
    def create(self) -> None: ...
    def write(self, level: int, block: npt.NDArray[np.float32], origin: ZYX) -> None: ...
    def write_cartesian(self, block: npt.NDArray[np.float32], origin: ZYX) -> None: ...
    def write_reduced(self, level: int, unit: int) -> None: ...
    def finish_cartesian(self) -> None: ...
    def write_lattice(self, level: int, unit: int) -> None: ...
    def finish(self) -> List[ZYX]: ...
