"""The small scenarios the calibration tests fit (tests/analysis)."""

from __future__ import annotations


def calibration_scenario(
    angles=(45.0,),
    speeds=(1.0,),
    *,
    std=10.0,
    samples=600,
    particles=None,
    name="tiny",
):
    """A fast scenario as parsed TOML data: one-size 50 µm particles (or
    `particles`) on a normal-rough surface of spread `std` [deg], the paper's
    power laws, a sweep of `speeds` x `angles`."""
    return {
        "name": name,
        "seed": 1,
        "samples": samples,
        "particles": particles or {"distribution": "monodisperse", "diameter_um": 50.0},
        "coefficients": {
            "k1": 4.0,
            "k2": {"law": "power", "a_m_s": 0.05, "b": -1.58, "d_ref_um": 52.8},
            "v_c": {"law": "power", "a_m_s": 0.2, "b": -1.58, "d_ref_um": 52.8},
            "p": 1.0,
            "q": 1.0,
            "friction": 0.15,
        },
        "surfaces": [{"name": "rough", "kind": "normal", "std_deg": std}],
        "sweep": {"speed_m_s": list(speeds), "angle_deg": list(angles)},
    }
