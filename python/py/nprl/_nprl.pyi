"""Type stubs of the native module (Rust, PyO3); the public API is the
package's: nprl.LWRRegressor, nprl.least_squares, nprl.ddp, nprl.envs."""
from typing import Any, Callable, Optional, Sequence

import numpy as np
import numpy.typing as npt

__version__: str

class LwrError(ValueError): ...
class LeastSquaresError(ValueError): ...
class DdpError(ValueError): ...

class LwrCore:
    @staticmethod
    def fit(
        x: npt.NDArray[np.float64],
        y: npt.NDArray[np.float64],
        kernel_name: str,
        degree_name: str,
        bandwidth: Optional[float],
        tune_evals: int,
        tune_points: int,
        confidence_level: float,
        tune_method: str,
    ) -> "LwrCore": ...
    def predict(
        self, x: npt.NDArray[np.float64]
    ) -> tuple[
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
        npt.NDArray[np.float64],
    ]: ...
    def jacobian(self, x: npt.NDArray[np.float64]) -> npt.NDArray[np.float64]: ...
    def settings(self) -> dict[str, Any]: ...
    def insert(self, x: npt.NDArray[np.float64], y: npt.NDArray[np.float64]) -> None: ...
    @property
    def n_inputs(self) -> int: ...
    @property
    def n_outputs(self) -> int: ...
    @property
    def n_points(self) -> int: ...
    def to_json(self) -> bytes: ...
    @staticmethod
    def from_json(bytes: bytes, tune_evals: int, tune_objective: Optional[float]) -> "LwrCore": ...

class Plant:
    def __init__(self, which: str = "robot", lag: float = 0.0) -> None: ...
    def step(
        self, state: tuple[float, float, float, float], a: float, u: float
    ) -> tuple[tuple[float, float, float, float], float]: ...
    def params(self) -> dict[str, float]: ...

def sensor_noise() -> tuple[float, float, float, float]: ...
def least_squares(
    fun: Callable[[npt.NDArray[np.float64]], Any],
    x0: npt.NDArray[np.float64],
    f0: npt.NDArray[np.float64],
    jac: Optional[Callable[[npt.NDArray[np.float64]], Any]],
    difference: str,
    sparsity: Optional[tuple[Sequence[int], Sequence[int]]],
    lower: Optional[Sequence[float]],
    upper: Optional[Sequence[float]],
    method: str,
    loss: str,
    f_scale: float,
    ftol: float,
    xtol: float,
    gtol: float,
    max_iterations: int,
    max_nfev: Optional[int],
) -> dict[str, Any]: ...
def ddp(
    model: Any,
    x0: Sequence[float],
    horizon: int,
    n_controls: int,
    jac: Optional[Callable[..., Any]],
    q: Sequence[float],
    r: Sequence[float],
    qf: Sequence[float],
    target: Sequence[float],
    u_init: Optional[Sequence[Sequence[float]]],
    lower: Optional[Sequence[float]],
    upper: Optional[Sequence[float]],
    method: str,
    max_iterations: Optional[int],
) -> dict[str, Any]: ...
def swingup_defaults(system: str) -> dict[str, Any]: ...
