"""Seed 001's robust Kalman filter (Sayed 2001; the thesis's Theorem 3.4), no rclpy.

The model is uncertain in F and G:

    x_{i+1} = (F + dF) x_i + (G + dG) w_i,   z_i = H x_i + v_i,   [dF dG] = M Delta [E_f E_g],
    ||Delta|| <= 1.

Each step picks a scalar lambda_hat > lambda_l = ||M^T H^T R^-1 H M|| (eq. 3.37), replaces
Q, R, P, G, F by the modified quantities of eqs. 3.38-3.43 and runs a predictor-corrector update
(eqs. 3.44-3.49). With lambda_hat = 0 every modified quantity is the nominal one and the step is
the nominal filter in its filtered form (seed 001 section 2):

    P_{i+1|i+1} = ((G Q G^T + F P F^T)^-1 + H^T R^-1 H)^-1
    x_{i+1|i+1} = F x_{i|i} + P_{i+1|i+1} H^T R^-1 (z_{i+1} - H F x_{i|i})

lambda_hat rules (`LambdaRule`):
- ``nominal``: lambda_hat = 0, the nominal filter;
- ``cheap``: lambda_hat = (1 + alpha) lambda_l (Sayed's suggestion; the same every step);
- ``exact``: lambda_hat = argmin_{lambda > lambda_l} G(lambda) (eq. 3.20 prints "arg max": an
  erratum). G depends on the next measurement, so the exact rule can only choose lambda_hat once
  z_{i+1} is known. The *prediction* this filter reports before the measurement arrives (`mean`
  after `predict`) therefore uses the lambda_hat of the previous step; the correction then uses
  the lambda_hat that minimises G for the new measurement, exactly as Theorem 3.4.

Errata of the thesis applied here (each marked at its equation): argmin in 3.20; no inverse on
the last factor of F_hat in 3.43; G(lambda)'s first term weighted by Q, not Q_hat, in 3.21.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from enum import StrEnum

import numpy as np

from tracker_filter.banks import FilterBank, ObjectBank
from tracker_filter.filters import StateFilter, check_measurement
from tracker_filter.models import AXES, LinearModel, model_for_layout


class LambdaRule(StrEnum):
    NOMINAL = "nominal"
    CHEAP = "cheap"
    EXACT = "exact"


@dataclass(frozen=True, eq=False)
class ModelUncertainty:
    """[dF dG] = M Delta [E_f E_g] with ||Delta|| <= 1: M (n, k), E_f (k, n), E_g (k, m)."""

    M: np.ndarray
    E_f: np.ndarray
    E_g: np.ndarray

    def __post_init__(self) -> None:
        m, e_f, e_g = (
            np.atleast_2d(np.asarray(a, dtype=float)) for a in (self.M, self.E_f, self.E_g)
        )
        if m.shape[1] != e_f.shape[0] or e_f.shape[0] != e_g.shape[0]:
            raise ValueError(
                f"M must be n x k and E_f, E_g k x n and k x m; got {m.shape}, {e_f.shape}, "
                f"{e_g.shape}"
            )
        if not all(np.all(np.isfinite(a)) for a in (m, e_f, e_g)):
            raise ValueError("M, E_f and E_g must be finite")
        object.__setattr__(self, "M", m)
        object.__setattr__(self, "E_f", e_f)
        object.__setattr__(self, "E_g", e_g)

    def check(self, model: LinearModel) -> None:
        """Raises ValueError when the shapes do not fit `model` (n states, m noise inputs)."""
        n, m = model.noise_gain.shape
        if self.M.shape[0] != n or self.E_f.shape[1] != n or self.E_g.shape[1] != m:
            raise ValueError(
                f"the model has {n} states and {m} noise inputs: M must be {n} x k, E_f k x {n}, "
                f"E_g k x {m}; got {self.M.shape}, {self.E_f.shape}, {self.E_g.shape}"
            )


def seed001_uncertainty() -> ModelUncertainty:
    """Seed 001's values: E_f = [0 0 1 1 1 1], E_g = [1 1 0 0 0 0], M = [.2 .2 .1 .1 .1 .1]^T."""
    return ModelUncertainty(
        M=np.array([[0.2], [0.2], [0.1], [0.1], [0.1], [0.1]]),
        E_f=np.array([[0.0, 0.0, 1.0, 1.0, 1.0, 1.0]]),
        E_g=np.array([[1.0, 1.0, 0.0, 0.0, 0.0, 0.0]]),
    )


def _measurement_matrix(n: int) -> np.ndarray:
    return np.hstack([np.eye(AXES), np.zeros((AXES, n - AXES))])


def lambda_lower_bound(model: LinearModel, uncertainty: ModelUncertainty) -> float:
    """lambda_l = ||M^T H^T R^-1 H M|| (eq. 3.37, spectral norm); 0 when H M = 0."""
    hm = uncertainty.M[:AXES]
    return float(np.linalg.norm(hm.T @ np.linalg.solve(model.measurement_covariance, hm), 2))


def initial_estimate(
    z0: np.ndarray, prior_covariance: np.ndarray, measurement_covariance: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Step 0 (eqs. 3.35-3.36) with prior mean 0: P = (Pi0^-1 + H^T R^-1 H)^-1, x = P H^T R^-1 z0."""
    n = prior_covariance.shape[0]
    h = _measurement_matrix(n)
    r_inv = np.linalg.inv(measurement_covariance)
    covariance = np.linalg.inv(np.linalg.inv(prior_covariance) + h.T @ r_inv @ h)
    return covariance @ h.T @ r_inv @ z0, covariance


@dataclass(frozen=True)
class ModifiedModel:
    """Step 2's quantities for one lambda_hat (eqs. 3.38-3.43)."""

    lam: float
    Q: np.ndarray  # Q_hat
    R: np.ndarray  # R_hat
    P: np.ndarray  # P_hat_{i|i}
    G: np.ndarray  # G_hat
    F: np.ndarray  # F_hat


def _inverse(matrix: np.ndarray) -> np.ndarray:
    """Inverse of a small k x k matrix; a division for seed 001's k = 1 (a tenth of the time)."""
    return 1.0 / matrix if matrix.shape == (1, 1) else np.linalg.inv(matrix)


#: exact rule search: lambda = lambda_l (1 + 10^s) for s in this range.
#: G can keep falling towards either end. Towards lambda_l, R_hat = R - H M M^T H^T / lambda turns
#: singular (seed 001: its small eigenvalue is ~3 (lambda / lambda_l - 1)), so the search stops
#: at 1e-3 above; beyond 1e4 lambda_l G changes by less than 1e-4 of itself.
EXACT_SEARCH_DECADES = (-3.0, 4.0)
EXACT_GRID_POINTS = 141  # 0.05 decades apart; G costs a few flops per point
_SEARCH_GRID = np.linspace(*EXACT_SEARCH_DECADES, EXACT_GRID_POINTS)


class RobustModel:
    """The uncertain model with every product of its matrices that no step changes, so that a
    step computes only what depends on P_{i|i}, lambda_hat and z_{i+1}."""

    def __init__(self, model: LinearModel, uncertainty: ModelUncertainty) -> None:
        uncertainty.check(model)
        self.model, self.uncertainty = model, uncertainty
        F, G = model.transition_matrix, model.noise_gain
        Q, R = model.process_covariance, model.measurement_covariance
        e_f, e_g = uncertainty.E_f, uncertainty.E_g
        k = e_f.shape[0]
        self.k = k
        self.lower_bound = lambda_lower_bound(model, uncertainty)
        self._identity = np.eye(k)
        self._qe = Q @ e_g.T  # Q E_g^T
        self._gqg = e_g @ self._qe  # E_g Q E_g^T
        h_bar = uncertainty.M[:AXES]  # H M
        self._hmmh = h_bar @ h_bar.T
        # G(lambda) (see `cost_terms`): C = [E_a; A] split into its state and noise columns
        self._cost_rows = np.vstack([e_f, F[:AXES]])  # [E_f; H F]
        noise_rows = np.vstack([e_g, G[:AXES]])  # [E_g; H G]
        constant = noise_rows @ Q @ noise_rows.T
        constant[k:, k:] += R
        self._cost_constant = constant
        coupling = np.zeros_like(constant)
        coupling[:k, :k] = np.eye(k)
        coupling[k:, k:] = -self._hmmh
        self._cost_coupling = coupling
        self._search_lambdas = self.lower_bound * (1.0 + 10.0**_SEARCH_GRID)

    def modified(self, covariance: np.ndarray, lam: float) -> ModifiedModel:
        """Step 2 of Theorem 3.4 for P_{i|i} = covariance; lam = 0 gives the nominal quantities."""
        model = self.model
        F, G = model.transition_matrix, model.noise_gain
        Q, R = model.process_covariance, model.measurement_covariance
        if lam == 0.0:
            return ModifiedModel(0.0, Q, R, covariance, G, F)
        e_f, e_g = self.uncertainty.E_f, self.uncertainty.E_g
        pe = covariance @ e_f.T
        outer = self._identity + lam * (e_f @ pe)  # I + lam E_f P E_f^T
        # (3.38) Q_hat^-1 = Q^-1 + lam E_g^T (I + lam E_f P E_f^T)^-1 E_g, inverted by Woodbury:
        # Q_hat = Q - Q E_g^T ((I + lam E_f P E_f^T) / lam + E_g Q E_g^T)^-1 E_g Q  (k x k inverses)
        q_hat = Q - self._qe @ _inverse(outer / lam + self._gqg) @ self._qe.T
        # (3.39) R_hat = R - lam^-1 H M M^T H^T
        r_hat = R - self._hmmh / lam
        # lam P_hat E_f^T = lam P E_f^T (I + lam E_f P E_f^T)^-1 (push-through identity): 3.41-3.43
        # need it, and without the difference of 3.41 it keeps its digits at large lambda_hat
        lam_pe_hat = lam * pe @ _inverse(outer)
        # (3.41) P_hat = P - P E_f^T (lam^-1 I + E_f P E_f^T)^-1 E_f P  (= 3.40 without inverting P)
        p_hat = covariance - lam_pe_hat @ pe.T
        # (3.42) G_hat = G - lam F P_hat E_f^T E_g
        g_hat = G - (F @ lam_pe_hat) @ e_g
        # (3.43) F_hat = (F - lam G_hat Q_hat E_g^T E_f)(I - lam P_hat E_f^T E_f)
        # erratum: the thesis prints an inverse on the last factor; with it the result is wrong.
        first = F - (lam * g_hat @ (q_hat @ e_g.T)) @ e_f
        f_hat = first - (first @ lam_pe_hat) @ e_f
        return ModifiedModel(lam, q_hat, r_hat, p_hat, g_hat, f_hat)

    def cost_terms(self, mean: np.ndarray, covariance: np.ndarray, z: np.ndarray) -> _CostTerms:
        """G(lambda) of eq. 3.21 in closed form for the step from (x_{i|i}, P_{i|i}) to z_{i+1}.

        Theorem 3.3's identifications (the thesis omits them): unknown x = col(x_i - x_{i|i},
        w_i); Q -> diag(P^-1, Q^-1); W -> R^-1; A -> H [F G]; b -> z - H F x_{i|i};
        H_bar -> H M; E_a -> [E_f E_g]; E_b -> -E_f x_{i|i}; then (3.21)-(3.24):

            W(lambda) = W + W H_bar (lambda I - H_bar^T W H_bar)^+ H_bar^T W     (3.24)
            x(lambda) = (Q + lambda E_a^T E_a + A^T W(lambda) A)^-1
                        (A^T W(lambda) b + lambda E_a^T E_b)                      (3.22, 3.23)
            G(lambda) = ||x||^2_Q + lambda ||E_a x - E_b||^2 + ||A x - b||^2_W(lambda)  (3.21)

        (3.21) erratum: the first term is weighted by Q, not Q_hat.

        x(lambda) minimises that very sum, whose minimum is d^T (D^-1 + C Q^-1 C^T)^-1 d with
        C = [E_a; A], d = col(E_b, b), D = diag(lambda I, W(lambda)). For lambda > lambda_l,
        W(lambda)^-1 = R - H_bar H_bar^T / lambda (Woodbury), so D^-1 + C Q^-1 C^T = K + J / lambda
        with K = C diag(P, Q) C^T + diag(0, R) and J = diag(I, -H_bar H_bar^T), J fixed. With
        K = L L^T and L^-1 J L^-T = V diag(nu) V^T, g = V^T L^-1 d:

            G(lambda) = sum_i g_i^2 lambda / (lambda + nu_i)
        """
        rows = self._cost_rows
        K = rows @ covariance @ rows.T + self._cost_constant
        L_inv = np.linalg.inv(np.linalg.cholesky(K))
        nu, V = np.linalg.eigh(L_inv @ self._cost_coupling @ L_inv.T)
        d = -(rows @ mean)
        d[self.k :] += z
        return _CostTerms((V.T @ (L_inv @ d)) ** 2, nu)

    def exact_lambda(self, mean: np.ndarray, covariance: np.ndarray, z: np.ndarray) -> float:
        """lambda_hat = argmin_{lambda > lambda_l} G(lambda) (eq. 3.20, erratum: argmin, not
        argmax), over lambda_l (1 + 10^s), s in EXACT_SEARCH_DECADES.

        G (closed form, `cost_terms`) has a single stationary point in closed form when the
        uncertainty has rank one (k = 1, seed 001; see `_CostTerms.turning_point`): lambda_hat is
        exact. Otherwise G is evaluated on a grid of s and the parabola through the best point and
        its neighbours places the minimum between grid points (kept only where G is lower still).
        """
        terms = self.cost_terms(mean, covariance, z)
        low, high = float(self._search_lambdas[0]), float(self._search_lambdas[-1])
        turning = terms.turning_point()
        if turning is not None:
            return min(max(turning, low), high)
        costs = terms.costs(self._search_lambdas)
        best = int(np.argmin(costs))
        if 0 < best < EXACT_GRID_POINTS - 1:
            vertex = _vertex(_SEARCH_GRID[best - 1 : best + 2], costs[best - 1 : best + 2])
            if vertex is not None:
                lam: float = self.lower_bound * (1.0 + 10.0**vertex)
                if terms.cost(lam) < costs[best]:
                    return lam
        return float(self._search_lambdas[best])


@dataclass(frozen=True)
class _CostTerms:
    """G(lambda) = sum_i g2_i lambda / (lambda + nu_i) for one step (see `RobustModel.cost_terms`)."""

    g2: np.ndarray  # (k + 2,)
    nu: np.ndarray  # (k + 2,)

    def costs(self, lams: np.ndarray) -> np.ndarray:
        """G at each lambda > lambda_l of `lams`."""
        lams = lams[:, None]
        costs: np.ndarray = (self.g2 * lams / (lams + self.nu)).sum(axis=1)
        return costs

    def cost(self, lam: float) -> float:
        return float((self.g2 * lam / (lam + self.nu)).sum())

    def turning_point(self) -> float | None:
        """The minimiser of G over lambda > lambda_l when G has one term with nu > 0 and one with
        nu < 0 (the rest nu = 0, constant in lambda), as for a rank-one uncertainty: J then has
        one positive, one negative and otherwise zero eigenvalues, and so has L^-1 J L^-T.

        G'(lambda) = a^2 / (lambda + nu_+)^2 - b^2 / (lambda + nu_-)^2 with a^2 = g_+^2 nu_+,
        b^2 = -g_-^2 nu_-, both denominators positive for lambda > lambda_l >= -nu_-. So G falls
        from its pole while b (lambda + nu_+) > a (lambda + nu_-); if a > b it turns once, at
        lambda = (b nu_+ - a nu_-) / (a - b), else it falls for ever (inf: the search's end).
        None when G has another shape."""
        nu, g2 = self.nu.tolist(), self.g2.tolist()  # a few numbers: plain floats are faster
        tiny = 1e-12 * max(abs(v) for v in nu)
        up = [i for i, v in enumerate(nu) if v > tiny]
        down = [i for i, v in enumerate(nu) if v < -tiny]
        if len(up) != 1 or len(down) != 1:
            return None
        nu_up, nu_down = nu[up[0]], nu[down[0]]
        a = math.sqrt(g2[up[0]] * nu_up)
        b = math.sqrt(-g2[down[0]] * nu_down)
        if a <= b:
            return math.inf
        turning: float = (b * nu_up - a * nu_down) / (a - b)
        return turning


def _vertex(s: np.ndarray, g: np.ndarray) -> float | None:
    """The vertex of the parabola through three equally spaced points, if it is a minimum."""
    curvature = g[0] - 2.0 * g[1] + g[2]
    if not curvature > 0.0:
        return None
    return float(s[1] + 0.5 * (s[1] - s[0]) * (g[0] - g[2]) / curvature)


def modified_model(
    model: LinearModel, uncertainty: ModelUncertainty, covariance: np.ndarray, lam: float
) -> ModifiedModel:
    """Step 2 of Theorem 3.4 for P_{i|i} = covariance (see `RobustModel.modified`)."""
    return RobustModel(model, uncertainty).modified(covariance, lam)


def regularised_cost(
    lam: float,
    model: LinearModel,
    uncertainty: ModelUncertainty,
    mean: np.ndarray,
    covariance: np.ndarray,
    z: np.ndarray,
) -> float:
    """G(lambda) of eq. 3.21 for the step from (x_{i|i}, P_{i|i}) to the measurement z_{i+1}
    (lambda > lambda_l; see `RobustModel.cost_terms`)."""
    return RobustModel(model, uncertainty).cost_terms(mean, covariance, z).cost(lam)


def exact_lambda(
    model: LinearModel,
    uncertainty: ModelUncertainty,
    mean: np.ndarray,
    covariance: np.ndarray,
    z: np.ndarray,
    lower_bound: float | None = None,
) -> float:
    """lambda_hat of the exact rule (see `RobustModel.exact_lambda`); `lower_bound` is
    lambda_l, computed when not given."""
    robust = RobustModel(model, uncertainty)
    if lower_bound is not None and not math.isclose(lower_bound, robust.lower_bound):
        raise ValueError(f"lambda_l is {robust.lower_bound}, not {lower_bound}")
    return robust.exact_lambda(mean, covariance, z)


class RobustKalmanFilter:
    """Sayed's robust filter as a `StateFilter`, one model step per `predict` (one frame).

        predict   x_{i+1|i} = F_hat x_{i|i}                                   (3.44)
        update    P_{i+1|i} = F P_hat F^T + G_hat Q_hat G_hat^T               (3.47)
                  R_e = R_hat + H P_{i+1|i} H^T                               (3.49)
                  P_{i+1|i+1} = P_{i+1|i} - P_{i+1|i} H^T R_e^-1 H P_{i+1|i}  (3.48)
                  x_{i+1|i+1} = x_{i+1|i} + P_{i+1|i+1} H^T R_hat^-1 e        (3.45, 3.46)

    A missed measurement keeps the prediction and P_{i+1|i}.
    """

    def __init__(
        self,
        models: RobustModels,
        mean: np.ndarray,
        covariance: np.ndarray,
        t0: float,
        rule: LambdaRule = LambdaRule.EXACT,
        alpha: float = 0.5,
    ) -> None:
        if not math.isfinite(t0):
            raise ValueError(f"start time must be finite, got {t0}")
        self.models = models
        self.robust = models.given
        self.model = self.robust.model
        self.rule, self.alpha = LambdaRule(rule), alpha
        self.lower_bound = self.robust.lower_bound
        self._filtered = (np.array(mean, dtype=float), np.array(covariance, dtype=float))
        self._time = float(t0)
        self._pending = False  # a predict() waits for its update()
        self.lam = self._fixed_lambda() if self.rule is not LambdaRule.EXACT else self._cheap()
        self._modified = self.robust.modified(self._filtered[1], self.lam)

    def _cheap(self) -> float:
        return (1.0 + self.alpha) * self.lower_bound

    def _fixed_lambda(self) -> float:
        if self.rule is LambdaRule.NOMINAL or self.lower_bound == 0.0:
            return 0.0  # H M = 0: Step 1 takes lambda_hat = 0
        return self._cheap()

    @property
    def state_layout(self) -> tuple[str, ...]:
        return self.model.state_layout

    @property
    def time(self) -> float:
        return self._time

    @property
    def mean(self) -> np.ndarray:
        """x_{i+1|i} between predict and update, else x_{i|i}."""
        if self._pending:
            predicted: np.ndarray = self._modified.F @ self._filtered[0]
            return predicted
        return self._filtered[0].copy()

    @property
    def covariance(self) -> np.ndarray:
        if self._pending:
            return self._predicted_covariance(self._modified)
        return self._filtered[1].copy()

    def _predicted_covariance(self, modified: ModifiedModel) -> np.ndarray:
        F = self.model.transition_matrix  # the nominal F of this step's model
        # (3.47)
        predicted: np.ndarray = F @ modified.P @ F.T + modified.G @ modified.Q @ modified.G.T
        return predicted

    def predict(self, t: float) -> None:
        if not math.isfinite(t) or t < self._time:
            raise ValueError(f"cannot predict from t = {self._time} s back to t = {t} s")
        if t == self._time and not self._pending:
            return
        if self._pending:
            self.update(None)  # the previous step ended without a measurement
        self.robust = self.models.at(t - self._time)
        self.model = self.robust.model
        # the exact rule keeps the previous step's lambda_hat until the measurement arrives
        self._modified = self.robust.modified(self._filtered[1], self.lam)
        self._pending = True
        self._time = float(t)

    def update(self, z: np.ndarray | None) -> None:
        z = check_measurement(z)
        if not self._pending:
            if z is not None:  # a second measurement at the same time: correct, no model step
                self._correct(
                    self._filtered[0], self._filtered[1], self.model.measurement_covariance, z
                )
            return
        mean, covariance = self._filtered
        if z is not None and self.rule is LambdaRule.EXACT and self.lower_bound > 0.0:
            self.lam = self.robust.exact_lambda(mean, covariance, z)
            self._modified = self.robust.modified(covariance, self.lam)
        modified = self._modified
        predicted = modified.F @ mean  # (3.44)
        predicted_cov = self._predicted_covariance(modified)
        self._pending = False
        if z is None:
            self._filtered = (predicted, predicted_cov)
            return
        self._correct(predicted, predicted_cov, modified.R, z)

    def _correct(
        self, predicted: np.ndarray, predicted_cov: np.ndarray, r_hat: np.ndarray, z: np.ndarray
    ) -> None:
        h_p = predicted_cov[:AXES]  # H P_{i+1|i}
        r_e = r_hat + h_p[:, :AXES]  # (3.49)
        filtered_cov = predicted_cov - h_p.T @ np.linalg.solve(r_e, h_p)  # (3.48)
        filtered_cov = (filtered_cov + filtered_cov.T) / 2.0  # round-off would make it drift
        innovation = z - predicted[:AXES]  # (3.46)
        gain = filtered_cov[:, :AXES] @ np.linalg.inv(r_hat)
        self._filtered = (predicted + gain @ innovation, filtered_cov)  # (3.45)

    def measurement_prediction(self) -> tuple[np.ndarray, np.ndarray]:
        """H x_{i+1|i} and R_e = R_hat + H P_{i+1|i} H^T (3.49)."""
        covariance = self.covariance
        return self.mean[:AXES], covariance[:AXES, :AXES] + self._modified.R

    def predicted_position(self, lead: float) -> np.ndarray:
        """Position after one more model step (the model has no other interval)."""
        return (self._modified.F @ self.mean)[:AXES] if lead > 0 else self.mean[:AXES]


class RobustModels:
    """The step's RobustModel: the given one every step, or (`from_stamps`) the given model with
    F the kinematic transition over the step's interval (G, Q, R and the uncertainty per step as
    given; a few intervals are kept, a replay has one or two)."""

    KEPT = 8

    def __init__(
        self, model: LinearModel, uncertainty: ModelUncertainty, from_stamps: bool = False
    ) -> None:
        self.given = RobustModel(model, uncertainty)
        self.kinematic = model_for_layout(model.state_layout) if from_stamps else None
        self._by_interval: dict[float, RobustModel] = {}

    def at(self, interval: float) -> RobustModel:
        if self.kinematic is None:
            return self.given
        key = round(interval, 9)
        found = self._by_interval.get(key)
        if found is None:
            given = self.given.model
            model = replace(given, transition_matrix=self.kinematic.transition(key))
            found = RobustModel(model, self.given.uncertainty)
            if len(self._by_interval) >= self.KEPT:
                self._by_interval.pop(next(iter(self._by_interval)))
            self._by_interval[key] = found
        return found


@dataclass(frozen=True, eq=False)
class RobustKalmanConfig:
    """Robust Kalman filters for new tracks; a `FilterFactory`.

    A new track starts with Step 0 (eqs. 3.35-3.36): prior mean 0 and Pi0 = initial_std^2 I.
    `from_stamps`: the model's F is the kinematic transition over each step's interval (the state
    must be x y vx vy or x y vx vy ax ay), so velocities are px/s at any frame rate; otherwise one
    step of the given matrices per frame, as the thesis (T = 1/20 s).
    """

    model: LinearModel
    uncertainty: ModelUncertainty = field(default_factory=seed001_uncertainty)
    rule: LambdaRule = LambdaRule.EXACT
    alpha: float = 0.5
    initial_std: float = 100.0
    from_stamps: bool = False

    def __post_init__(self) -> None:
        object.__setattr__(self, "rule", LambdaRule(self.rule))
        self.uncertainty.check(self.model)
        if not (math.isfinite(self.alpha) and self.alpha > 0.0):
            raise ValueError(f"alpha must be a positive number, got {self.alpha}")
        if not (math.isfinite(self.initial_std) and self.initial_std > 0.0):
            raise ValueError(f"initial_std must be a positive number, got {self.initial_std}")
        needs_inverse_q = self.rule is not LambdaRule.NOMINAL
        if needs_inverse_q and np.linalg.eigvalsh(self.model.process_covariance).min() <= 0.0:
            raise ValueError("the robust filter needs a positive definite Q (it uses Q^-1)")
        object.__setattr__(
            self, "_models", RobustModels(self.model, self.uncertainty, self.from_stamps)
        )

    @property
    def state_layout(self) -> tuple[str, ...]:
        return self.model.state_layout

    def new_filter(self, z: np.ndarray, t: float) -> StateFilter:
        z0 = check_measurement(z)
        if z0 is None:
            raise ValueError("a new track needs a measurement")
        prior = np.eye(self.model.dim) * self.initial_std**2
        mean, covariance = initial_estimate(z0, prior, self.model.measurement_covariance)
        models: RobustModels = self._models  # type: ignore[attr-defined]
        return RobustKalmanFilter(models, mean, covariance, t, self.rule, self.alpha)

    def new_bank(self) -> FilterBank:
        return ObjectBank(self.new_filter, self.state_layout)
