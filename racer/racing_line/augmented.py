"""An augmented Lagrangian solver for a stage of the line: min f(x) subject to low <= A x <= high.

SLSQP's dense QP costs of the order of controls² × constraint rows per iteration (penbay_pro's last stage: 446
controls, 3,568 rows), so a long track's stages take minutes. Here the rows enter the objective instead, through the
Powell-Hestenes-Rockafellar augmented Lagrangian for two-sided constraints (Nocedal & Wright, Numerical Optimization,
2nd ed., §17.3-17.4; Birgin & Martínez, Practical Augmented Lagrangian Methods for Constrained Optimization, 2014):

    L(x; y, ρ) = f(x) + ρ/2 ‖A x + y/ρ − Π(A x + y/ρ)‖² − ‖y‖² / (2ρ),

Π the projection onto [low, high] row by row, y the multipliers (positive on a high bound, negative on a low one).
scipy's BFGS (a dense inverse Hessian) minimises L for fixed y and ρ, stopped as SLSQP stops; then
y ← ρ (A x + y/ρ − Π(A x + y/ρ)), and ρ grows tenfold when the worst violation did not at least halve. An inner
iteration costs one lap-time gradient, two products with A and O(controls²) for the Hessian, whatever the rows.
SLSQP without constraints as the inner solver found the same lines but costs O(controls³) an iteration (0.15 s at
446 controls: penbay_pro took 349 s).
L-BFGS-B, the usual inner solver, stalled: the lap time's minimum over stations has kinks where its gradient jumps,
and from racer_oval's last stage's start it stopped at 3.5348 s where SLSQP, with the rows as constraints, went on to
3.5236 s and BFGS to 3.5238 s (a straight path led down from its point; its gradient, 48 s/m, pointed
into a kink 1e-7 m away).

The bounds are tightened by the feasibility tolerance first, so a result within it of the tightened bounds has every
row inside the bounds as given.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from scipy.optimize import OptimizeResult, minimize

Objective = Callable[[np.ndarray], tuple[float, np.ndarray]]
"""Controls -> (value, gradient)."""


@dataclass(frozen=True)
class AugmentedLagrangianSettings:
    feasibility_m: float = 1e-5
    """The bounds are tightened by this and the search stops when no row is further outside them: every station ends
    inside its bounds, which lose 1/500 of the 5 mm border margin."""
    ftol_s: float = 1e-6
    """An inner solve stops when an iteration gains less than this, and the search when an outer iteration does with
    every row inside: SLSQP's test and value (`optimiser.FTOL_S`)."""
    penalty_growth: float = 10.0
    violation_shrink: float = 0.5
    """ρ grows by `penalty_growth` after an outer iteration that did not shrink the worst violation by this factor:
    the values ALGENCAN uses (Birgin & Martínez)."""
    initial_penalty_per_objective: float = 10.0
    """ρ₀ = this × max(1, |f(x₀)|) per m²: from a feasible start (each stage starts on the line the one before found)
    ALGENCAN's rule for ρ₀ reduces to this."""
    max_inner_iterations: int = 1000
    """Per inner solve: SLSQP's cap for a whole stage (`optimiser.MAX_ITERATIONS`)."""
    max_outer_iterations: int = 40
    """Against a runaway: ρ would have grown by 10⁴⁰."""


@dataclass(frozen=True)
class AugmentedLagrangianResult:
    controls: np.ndarray
    iterations: int
    """Inner iterations over all outer ones."""
    worst_violation_m: float
    """The furthest any row lies outside the bounds as given (≤ 0: all inside)."""
    message: str


def augmented_lagrangian(
    objective: Objective,
    start: np.ndarray,
    matrix: np.ndarray,
    low: np.ndarray,
    high: np.ndarray,
    settings: AugmentedLagrangianSettings,
    on_iteration: Callable[[np.ndarray], None] | None = None,
) -> AugmentedLagrangianResult:
    """Minimise `objective` over x subject to `low` <= `matrix` @ x <= `high`, from `start`."""
    inner_low = low + settings.feasibility_m
    inner_high = np.maximum(high - settings.feasibility_m, inner_low)  # a row narrower than twice the tolerance
    controls = np.asarray(start, dtype=np.float64).copy()
    multipliers = np.zeros(matrix.shape[0])
    penalty = settings.initial_penalty_per_objective * max(1.0, abs(objective(controls)[0]))
    previous_violation, previous_value = np.inf, np.inf
    iterations = 0
    message = "the outer iteration cap was reached"
    for _ in range(settings.max_outer_iterations):

        def lagrangian(x: np.ndarray, y: np.ndarray = multipliers, rho: float = penalty) -> tuple[float, np.ndarray]:
            value, gradient = objective(x)
            shifted = matrix @ x + y / rho
            excess = shifted - np.clip(shifted, inner_low, inner_high)
            return value + 0.5 * rho * (excess @ excess) - (y @ y) / (2 * rho), gradient + matrix.T @ (rho * excess)

        inner = minimize(
            lagrangian,
            controls,
            jac=True,
            method="BFGS",
            options={"maxiter": settings.max_inner_iterations, "gtol": 0.0},
            callback=_FtolStop(settings.ftol_s, on_iteration),
        )
        iterations += inner.nit
        controls = inner.x
        rows = matrix @ controls
        shifted = rows + multipliers / penalty
        multipliers = penalty * (shifted - np.clip(shifted, inner_low, inner_high))
        violation = float(np.max(np.maximum(inner_low - rows, rows - inner_high)))
        value = objective(controls)[0]
        if violation <= settings.feasibility_m and abs(previous_value - value) < settings.ftol_s:
            message = "feasible, and an outer iteration gained less than ftol"
            break
        if violation > settings.violation_shrink * previous_violation:
            penalty *= settings.penalty_growth
        previous_violation, previous_value = violation, value
    rows = matrix @ controls
    worst = float(np.max(np.maximum(low - rows, rows - high)))
    return AugmentedLagrangianResult(controls, iterations, worst, message)


class _FtolStop:
    """scipy's BFGS has no test on the objective's gain: this stops it when an iteration gains less than `ftol_s`, the
    test SLSQP makes."""

    def __init__(self, ftol_s: float, on_iteration: Callable[[np.ndarray], None] | None) -> None:
        self.ftol_s, self.on_iteration = ftol_s, on_iteration
        self.previous = np.inf

    def __call__(self, intermediate_result: OptimizeResult) -> None:
        if self.on_iteration is not None:
            self.on_iteration(intermediate_result.x)
        gain, self.previous = self.previous - intermediate_result.fun, intermediate_result.fun
        if gain < self.ftol_s:
            raise StopIteration
