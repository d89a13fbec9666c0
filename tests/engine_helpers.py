"""Small test doubles for engine tests: any object with ``table()`` and ``describe()``
is a distribution for the engine, and any object with ``evaluate(d)``, ``p``, ``q``,
``friction`` and ``describe()`` is a set of coefficient laws."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.testing import assert_array_equal
from scipy import stats

from microimpact._core.tables import QuantileTable
from microimpact.scenario.scenario import Scenario, SurfaceVariant


@dataclass(frozen=True)
class FrozenDist:
    dist: object
    label: str = "test"

    def table(self):
        return QuantileTable.from_ppf(self.dist.ppf)

    def ppf(self, q):
        return self.dist.ppf(q)

    def describe(self):
        return {"kind": self.label, "repr": repr(self.dist)}


@dataclass(frozen=True)
class PowerCoefficients:
    """k1, k2 constant; v_c = vc_ref (d / d_ref)^b."""

    k1: float = 5.0
    k2: float = 0.05
    vc_ref: float = 0.2
    b: float = -1.0
    d_ref: float = 50e-6
    p: float = 1.0
    q: float = 1.0
    friction: float = math.inf

    def v_c(self, d):
        return self.vc_ref * (np.asarray(d) / self.d_ref) ** self.b

    def evaluate(self, d):
        d = np.asarray(d, dtype=float)
        return np.full_like(d, self.k1), np.full_like(d, self.k2), self.v_c(d)

    def describe(self):
        return {"k1": self.k1}


def normal_diameters(mean_um=52.8, std_um=15.3):
    mean, std = mean_um * 1e-6, std_um * 1e-6
    return FrozenDist(stats.truncnorm(-mean / std, np.inf, loc=mean, scale=std))


def normal_angles(std_deg, mean_deg=0.0):
    return FrozenDist(stats.norm(np.deg2rad(mean_deg), np.deg2rad(std_deg)))


def scenario(**kw):
    base = dict(
        name="test",
        particles=normal_diameters(),
        coefficients=PowerCoefficients(),
        speeds_m_s=(0.2,),
        angles_deg=(90.0,),
        surfaces=(SurfaceVariant("smooth"),),
        seed=12345,
    )
    base.update(kw)
    return Scenario(**base)


def rough(std_deg=10.0, mean_deg=0.0, name="rough"):
    return SurfaceVariant(name, normal_angles(std_deg, mean_deg))


def correlated_areal_angles(n, seed=5, std_par=18.0, std_perp=14.0, rho=0.3):
    """An areal angle set of `n` joint (phi_par, phi_perp) [deg] draws: bivariate
    normal, standard deviations `std_par`, `std_perp`, correlation `rho`."""
    from microimpact.surface.areal_angles import areal_angles_from_sample

    rng = np.random.default_rng(seed)
    a = rng.normal(0.0, std_par, n)
    b = rho * a * std_perp / std_par + rng.normal(
        0.0, std_perp * np.sqrt(1 - rho**2), n
    )
    return areal_angles_from_sample(a, b)


def two_surface_grid(**kw):
    """A 9 x 4 speed-angle grid on two rough surfaces, 3,000 impacts per point
    (normal incidence included); `kw` overrides."""
    base = dict(
        surfaces=(rough(8.0), rough(14.0, name="rougher")),
        speeds_m_s=tuple(np.linspace(0.1, 2.0, 9)),
        angles_deg=(20.0, 50.0, 80.0, 90.0),
        samples=3000,
    )
    base.update(kw)
    return scenario(**base)


def same_runs(a, b):
    """Two results of one run (seed and scenario): every summary column but the
    surface's name, and every accumulator, bit for bit."""
    cols = [c for c in a.summary.columns if c != "surface"]
    assert_array_equal(a.summary[cols].to_numpy(), b.summary[cols].to_numpy())
    for k in a.accumulators:
        assert a.accumulators[k] == b.accumulators[k], k
