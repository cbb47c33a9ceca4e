from typing import Any, List, Optional, Tuple

import dask.array as da

from ._boxforge import StorePlan

def bounds(samples: da.Array, spec: Any, brick: int = 32) -> da.Array: ...
def prefilter(samples: da.Array, spec: Any) -> da.Array: ...
def reduce(volume: da.Array, reduction: str = "box", chunks: Optional[Any] = None) -> da.Array: ...
def resample(volume: da.Array, lattice: str, chunks: Optional[Any] = None) -> da.Array: ...
def to_ome_zarr(
    volume: Any,
    path: Any,
    spec: Any = None,
    *,
    lattice: Optional[str] = None,
    chunk: int = 64,
    shard: Optional[int] = None,
    levels: Optional[int] = None,
    reduction: str = "box",
    dtype: Optional[str] = None,
    spacing: Tuple[float, float, float] = (1.0, 1.0, 1.0),
    unit: Optional[str] = None,
) -> List[Tuple[int, int, int]]: ...
def store_stages(volume: Any, plan: StorePlan) -> List[List[Any]]: ...
