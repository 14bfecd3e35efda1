"""Type stubs of the compiled module `eyereplay._native` (PyO3). Use the
functions of the `eyereplay` package; these are its building blocks."""

from typing import Any, Dict, List, Optional, Tuple

class EyereplayError(Exception): ...
class ConfigError(EyereplayError): ...
class SourceError(EyereplayError): ...
class VideoError(EyereplayError): ...
class ModelError(EyereplayError): ...
class DatasetError(EyereplayError): ...

def json_to_toml(label: str, json: str) -> str: ...
def extract(
    videos: List[str],
    out: Optional[str] = None,
    models: Optional[str] = None,
    threads: int = 0,
    blink_ratio: float = 0.6,
    max_seconds: Optional[float] = None,
    mesh_every: Optional[int] = None,
    iris_views: int = 1,
    device: str = "cpu",
    landmarks: Optional[str] = None,
    progress: Any = None,
) -> List[Dict[str, Any]]: ...
def prepare(
    config_path: Optional[str],
    config_toml: Optional[str],
    label: str,
    base_dir: Optional[str],
    out: Optional[str],
    cache: Optional[str] = None,
    dry_run: bool = False,
    progress: Any = None,
) -> Dict[str, Any]: ...
def generate(
    config_path: Optional[str],
    config_toml: Optional[str],
    label: str,
    base_dir: Optional[str],
    out: str,
    shard: Optional[str] = None,
    shards: Optional[int] = None,
    cache: Optional[str] = None,
    evaluate: bool = True,
    progress: Any = None,
) -> Dict[str, Any]: ...
def evaluate(
    dataset_dir: str,
    visual: bool = True,
    visual_session: Optional[str] = None,
    video: Optional[str] = None,
    trajectory: Optional[str] = None,
    visual_seconds: float = 120.0,
    models: Optional[str] = None,
    progress: Any = None,
) -> Dict[str, Any]: ...
def merge(dataset_dir: str, evaluate: bool = True, progress: Any = None) -> Optional[str]: ...
def detect(
    input: str,
    model: str,
    cache: Optional[str] = None,
    progress: Any = None,
) -> str: ...
def train(
    datasets: List[str],
    out: str,
    window_s: float = 10.0,
    input: str = "extracted",
    classifier: str = "trees",
    seed: int = 1,
    alpha: float = 1.0,
    noise_copies: int = 0,
    frame_labels: bool = False,
    max_fpr: float = 0.05,
    cache: Optional[str] = None,
    progress: Any = None,
) -> Dict[str, Any]: ...
def dataset_index(dataset_dir: str) -> Tuple[str, List[Dict[str, Any]]]: ...
def check_models(dir: Optional[str] = None) -> List[str]: ...
def default_models_dir() -> str: ...
def default_config() -> Optional[str]: ...
def version() -> str: ...
def use_package_files(models_dir: str, runtime_library: Optional[str] = None) -> None: ...
def use_package_faces(faces_dir: str) -> None: ...
def cache_dir() -> str: ...

class FrameExtractor:
    def __init__(
        self,
        width: int,
        height: int,
        models: Optional[str] = None,
        blink_ratio: float = 0.6,
        mesh_every: Optional[int] = None,
        iris_views: int = 1,
        device: str = "cpu",
        landmarks: Optional[str] = None,
    ) -> None: ...
    def push(self, data: bytes, times: List[float]) -> None: ...
    def finish(self) -> Dict[str, Any]: ...
