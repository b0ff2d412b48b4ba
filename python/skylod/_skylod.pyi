"""Type stubs of the native module ``skylod._skylod`` (PyO3). Use the package's functions
(``skylod.svf``, ...): they build the ``setup`` dicts and parse the JSON returned here."""

from os import PathLike
from pathlib import Path
from typing import Any, Callable, Dict, List, Optional, Sequence, Tuple, Union

_Path = Union[str, PathLike[str]]
_Progress = Optional[Callable[[str, int, int], Any]]

__version__: str

class SkylodError(Exception):
    """An error of the skylod library, with its message (file, line:column and gml:id where known)."""

def stats(
    paths: Sequence[_Path], source_crs: Optional[str] = None, progress: _Progress = None
) -> str: ...
def svf(setup: Dict[str, Any], rays: int, seed: int, progress: _Progress = None) -> str: ...
def sun_hours(
    setup: Dict[str, Any],
    site: Optional[Tuple[float, float]] = None,
    year: int = 2025,
    step: int = 15,
    timezone: str = "UTC",
    progress: _Progress = None,
) -> str: ...
def horizon(setup: Dict[str, Any], step: float = 1.0, progress: _Progress = None) -> str: ...
def irradiance(
    setup: Dict[str, Any],
    weather: _Path,
    site: Optional[Tuple[float, float]] = None,
    sky: str = "perez",
    albedo: float = 0.2,
    rays: int = 10000,
    seed: int = 1,
    progress: _Progress = None,
) -> str: ...
def evaluate(
    setup: Dict[str, Any],
    lod: Dict[str, Any],
    svf_rays: int = 20000,
    sun: bool = True,
    site: Optional[Tuple[float, float]] = None,
    year: int = 2025,
    step: int = 15,
    progress: _Progress = None,
) -> str: ...
def lod(
    setup: Dict[str, Any],
    output: _Path,
    lod: Dict[str, Any],
    bound: Dict[str, Any],
    format: Optional[str] = None,
    overwrite: bool = False,
    progress: _Progress = None,
) -> str: ...
def convert(
    paths: Sequence[_Path],
    output: _Path,
    format: Optional[str] = None,
    overwrite: bool = False,
    progress: _Progress = None,
) -> List[Path]: ...
