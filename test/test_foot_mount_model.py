"""Werner 2021 model: matrices against the paper's Appendix, poles and FRFs against the paper's
stated numbers (digest 8.1) and the reproduced reference values (digest 8.2-8.3)."""
import numpy as np
import pytest
from scipy.signal import find_peaks

from rotor_avc.closed_loop.frf import unbalance_frf
from rotor_avc.analysis.poles import machine_poles, undamped_poles
from rotor_avc.machine import load_machine

TWO_PI = 2 * np.pi
CASES = ["foot_mount_case1", "foot_mount_case2", "foot_mount_case3",
         "foot_mount_case2_4act", "foot_mount_case3_4act"]


def appendix_matrices(m_aa, c_a, c_f, m_fs, mach):
    """M and C written out entry by entry from the paper's Appendix (55)-(134) with the typos of
    (72) and (81) corrected (digest 3.3-3.4) -- independent of the kinematic assembly.

    m_aa[f], m_fs[f] (foundation + actuator-stator mass), c_a[f][q], c_f[q] per foot f."""
    aD, aN, bL, bR, h = mach["aD"], mach["aN"], mach["bL"], mach["bR"], mach["h"]
    DL, DR, NL, NR = "DL", "DR", "NL", "NR"
    S = sum(m_aa.values())
    M = np.zeros((19, 19))      # 1-based
    M[1, 1] = M[2, 2] = M[3, 3] = mach["m_sr"] + S
    M[1, 5] = aD * (m_aa[DL] + m_aa[DR]) - aN * (m_aa[NL] + m_aa[NR])
    M[1, 6] = bR * (m_aa[DR] + m_aa[NR]) - bL * (m_aa[DL] + m_aa[NL])
    M[2, 4] = -aD * (m_aa[DL] + m_aa[DR]) + aN * (m_aa[NL] + m_aa[NR])
    M[2, 6] = -h * S
    M[3, 4] = -bR * (m_aa[DR] + m_aa[NR]) + bL * (m_aa[DL] + m_aa[NL])
    M[3, 5] = h * S
    M[4, 4] = (mach["th_srz"] + bL**2 * (m_aa[DL] + m_aa[NL]) + bR**2 * (m_aa[DR] + m_aa[NR])
               + aD**2 * (m_aa[DL] + m_aa[DR]) + aN**2 * (m_aa[NL] + m_aa[NR]))
    M[4, 5] = h * bL * (m_aa[DL] + m_aa[NL]) - h * bR * (m_aa[DR] + m_aa[NR])
    M[4, 6] = h * aD * (m_aa[DL] + m_aa[DR]) - h * aN * (m_aa[NL] + m_aa[NR])
    M[5, 5] = mach["th_sry"] + aD**2 * (m_aa[DL] + m_aa[DR]) + aN**2 * (m_aa[NL] + m_aa[NR]) + h**2 * S
    M[5, 6] = aD * (bR * m_aa[DR] - bL * m_aa[DL]) + aN * (bL * m_aa[NL] - bR * m_aa[NR])
    M[6, 6] = mach["th_sx"] + bL**2 * (m_aa[DL] + m_aa[NL]) + bR**2 * (m_aa[DR] + m_aa[NR]) + h**2 * S
    for k, f in enumerate((DL, DR, NL, NR)):
        for off in (7, 11, 15):
            M[off + k, off + k] = m_fs[f]
    z = {f: c_a[f]["z"] for f in c_a}
    y = {f: c_a[f]["y"] for f in c_a}
    x = {f: c_a[f]["x"] for f in c_a}
    C = np.zeros((19, 19))
    C[1, 1] = z[DL] + z[DR] + z[NL] + z[NR]
    C[1, 5] = aD * (z[DL] + z[DR]) - aN * (z[NL] + z[NR])
    C[1, 6] = bR * (z[DR] + z[NR]) - bL * (z[DL] + z[NL])
    C[1, 7], C[1, 8], C[1, 9], C[1, 10] = -z[DL], -z[DR], -z[NL], -z[NR]
    C[2, 2] = y[DL] + y[DR] + y[NL] + y[NR]
    C[2, 4] = aN * (y[NL] + y[NR]) - aD * (y[DL] + y[DR])
    C[2, 6] = -h * (y[DL] + y[DR] + y[NL] + y[NR])
    C[2, 11], C[2, 12], C[2, 13], C[2, 14] = -y[DL], -y[DR], -y[NL], -y[NR]
    C[3, 3] = x[DL] + x[DR] + x[NL] + x[NR]
    C[3, 4] = bL * (x[DL] + x[NL]) - bR * (x[DR] + x[NR])
    C[3, 5] = h * (x[DL] + x[DR] + x[NL] + x[NR])
    C[3, 15], C[3, 16], C[3, 17], C[3, 18] = -x[DL], -x[DR], -x[NL], -x[NR]
    C[4, 4] = bL**2 * (x[DL] + x[NL]) + bR**2 * (x[DR] + x[NR]) + aD**2 * (y[DL] + y[DR]) + aN**2 * (y[NL] + y[NR])
    C[4, 5] = h * bL * (x[DL] + x[NL]) - h * bR * (x[DR] + x[NR])
    C[4, 6] = h * aD * (y[DL] + y[DR]) - h * aN * (y[NL] + y[NR])
    C[4, 11], C[4, 12], C[4, 13], C[4, 14] = aD * y[DL], aD * y[DR], -aN * y[NL], -aN * y[NR]
    C[4, 15], C[4, 16], C[4, 17], C[4, 18] = -bL * x[DL], bR * x[DR], -bL * x[NL], bR * x[NR]
    C[5, 5] = aD**2 * (z[DL] + z[DR]) + aN**2 * (z[NL] + z[NR]) + h**2 * (x[DL] + x[DR] + x[NL] + x[NR])
    C[5, 6] = aD * (bR * z[DR] - bL * z[DL]) + aN * (bL * z[NL] - bR * z[NR])
    C[5, 7], C[5, 8], C[5, 9], C[5, 10] = -aD * z[DL], -aD * z[DR], aN * z[NL], aN * z[NR]
    C[5, 15], C[5, 16], C[5, 17], C[5, 18] = -h * x[DL], -h * x[DR], -h * x[NL], -h * x[NR]
    C[6, 6] = bL**2 * (z[DL] + z[NL]) + bR**2 * (z[DR] + z[NR]) + h**2 * (y[DL] + y[DR] + y[NL] + y[NR])
    C[6, 7], C[6, 8], C[6, 9], C[6, 10] = bL * z[DL], -bR * z[DR], bL * z[NL], -bR * z[NR]
    C[6, 11], C[6, 12], C[6, 13], C[6, 14] = h * y[DL], h * y[DR], h * y[NL], h * y[NR]
    for k, f in enumerate((DL, DR, NL, NR)):
        C[7 + k, 7 + k] = c_f["z"] + z[f]
        C[11 + k, 11 + k] = c_f["y"] + y[f]
        C[15 + k, 15 + k] = c_f["x"] + x[f]
    M, C = M[1:, 1:], C[1:, 1:]
    M = np.triu(M) + np.triu(M, 1).T
    C = np.triu(C) + np.triu(C, 1).T
    return M, C


MACH = dict(aD=0.7, aN=0.7, bL=0.53, bR=0.53, h=0.56, m_sr=9100.0, th_srz=2900.0,
            th_sry=2900.0, th_sx=1500.0)
ACT = {"z": 1.05e7, "y": 2.62e7, "x": 2.62e7}
STIFF = {"z": 2.6e9, "y": 5.6e8, "x": 5.6e8}
C_F = {"z": 1.44e9, "y": 2.05e7, "x": 4.2e7}


@pytest.mark.parametrize("case,nr", [("foot_mount_case2", "stiff"), ("foot_mount_case2_4act", "act")])
def test_matrices_equal_appendix_formulas(case, nr):
    plant = load_machine(case).plant
    m_aa = {"DL": 15.0, "DR": 15.0, "NL": 15.0, "NR": 3.0 if nr == "stiff" else 15.0}
    m_fs = {"DL": 45.0, "DR": 45.0, "NL": 45.0, "NR": 15.0 if nr == "stiff" else 45.0}
    c_a = {"DL": ACT, "DR": ACT, "NL": ACT, "NR": STIFF if nr == "stiff" else ACT}
    M, C = appendix_matrices(m_aa, c_a, C_F, m_fs, MACH)
    np.testing.assert_allclose(plant.mass, M, rtol=1e-12, atol=1e-9)
    np.testing.assert_allclose(plant.stiffness, C, rtol=1e-12, atol=1e-3)
    # loss-factor damping: the same formulas with c -> c tan(delta) (eq. 8), tan(delta) = 0.04
    np.testing.assert_allclose(plant.loss_damping, 0.04 * C, rtol=1e-12, atol=1e-3)


def test_digest_regression_values_case2_and_case1():
    p2 = load_machine("foot_mount_case2").plant
    np.testing.assert_allclose(np.diag(p2.mass), [9148, 9148, 9148, 2937.0032, 2938.5728, 1528.536]
                               + [45, 45, 45, 15] * 3, rtol=1e-9)
    np.testing.assert_allclose(p2.stiffness[4, :6] / 1e6,
                               [-1812.65, 0, 357.616, -158.43184, 1489.69996, -960.7045], rtol=1e-9)
    np.testing.assert_allclose(np.diag(p2.stiffness)[6:] / 1e6,
                               [1450.5] * 3 + [4040] + [46.7] * 3 + [580.5] + [68.2] * 3 + [602],
                               rtol=1e-9)
    p1 = load_machine("foot_mount_case1").plant
    assert p1.n == 6
    M6 = np.array([[9140, 0, 0, 0, 0, 0], [0, 9140, 0, 0, 0, -22.4], [0, 0, 9140, 0, 22.4, 0],
                   [0, 0, 0, 2930.836, 0, 0], [0, 0, 22.4, 0, 2932.144, 0],
                   [0, -22.4, 0, 0, 0, 1523.78]])
    C6 = 1e6 * np.array([[5760, 0, 0, 0, 0, 0], [0, 584, 0, 0, 0, -327.04], [0, 0, 4000, 0, 2240, 0],
                         [0, 0, 0, 1409.76, 0, 0], [0, 0, 2240, 0, 4076.8, 0],
                         [0, -327.04, 0, 0, 0, 1801.1264]])
    np.testing.assert_allclose(p1.mass, M6, rtol=1e-9, atol=1e-9)
    np.testing.assert_allclose(p1.stiffness, C6, rtol=1e-9, atol=1e-3)


def test_undamped_natural_frequencies():
    expected = {"foot_mount_case1": [38.04, 82.89, 110.38, 126.35, 173.46, 198.34],
                "foot_mount_case2": [7.52, 9.39, 17.18, 19.76, 24.84, 104.66],
                "foot_mount_case2_4act": [6.96, 8.28, 10.74, 18.59, 21.32, 22.32]}
    for case, freqs in expected.items():
        poles = undamped_poles(load_machine(case).loop.open(), 0.0)
        f = np.sort(poles.imag[poles.imag > 0])[:6] / TWO_PI
        np.testing.assert_allclose(f, freqs, atol=0.006)
    # highest mode of case 2/3: local vertical mode of the stiff element at NR, ~2616 Hz
    poles = undamped_poles(load_machine("foot_mount_case2").loop.open(), 0.0)
    assert poles.imag.max() / TWO_PI == pytest.approx(2615.7, abs=0.1)


@pytest.mark.parametrize("case", CASES)
@pytest.mark.parametrize("speed_hz", [0.0, 250.0])
def test_all_cases_stable(case, speed_hz):
    """R7: no pole with a positive real part at f_r = 0 and 250 Hz."""
    res = machine_poles(load_machine(case), TWO_PI * speed_hz)
    assert res.stable
    assert res.max_real < -0.05


def test_worst_case_poles_match_reference():
    """Digest 8.2: worst-case iteration history and the six machine-mode poles."""
    ref = {
        "foot_mount_case1": ([1246.2, 1246.0], [-0.92 + 239.00j, -4.35 + 520.80j, -7.72 + 693.51j,
                                                -10.12 + 793.78j, -19.07 + 1089.69j, -24.93 + 1245.97j]),
        "foot_mount_case3": ([657.6, 656.9], [-11.45 + 48.42j, -22.17 + 59.34j, -14.73 + 100.30j,
                                              -8.04 + 129.94j, -27.96 + 137.36j, -25.58 + 656.92j]),
        "foot_mount_case3_4act": ([140.2, 126.7, 126.6], None),
    }
    for case, (hist, poles) in ref.items():
        res = machine_poles(load_machine(case), 0.0)
        np.testing.assert_allclose(res.history, hist, atol=0.06)
        if poles:
            got = np.array([complex(r["re"], r["im"]) for r in res.table()[:6]])
            np.testing.assert_allclose(got, poles, atol=0.0075)   # 2-decimal rounding of re and im
    yaw = [r for r in machine_poles(load_machine("foot_mount_case3_4act"), 0.0).table()
           if abs(r["freq_hz"] - 18.585) < 0.05]
    assert complex(yaw[0]["re"], yaw[0]["im"]) == pytest.approx(-2.15 + 116.77j, abs=0.006)


def test_rotation_about_x_mode_case1():
    """R4: the mode dominated by rotation about x at ~1088 rad/s (within 0.5 %)."""
    res = machine_poles(load_machine("foot_mount_case1"), 0.0)
    roll = [r for r in res.table() if 1000 < r["im"] < 1200]
    assert len(roll) == 1
    assert roll[0]["im"] == pytest.approx(1088.0, rel=0.005)


def _peaks(frf, key, prominence=3.0):
    d = frf.db(key)
    idx, _ = find_peaks(d, prominence=prominence)
    out = []
    for i in idx:       # parabolic refinement on the dB curve
        y0, y1, y2 = d[i - 1:i + 2]
        step = frf.speed_hz[1] - frf.speed_hz[0]
        out.append(frf.speed_hz[i] + 0.5 * step * (y0 - y2) / (y0 - 2 * y1 + y2))
    return np.array(out)


@pytest.fixture(scope="module")
def frf_case1():
    return unbalance_frf(load_machine("foot_mount_case1").loop, TWO_PI * np.arange(1.0, 250.0, 0.02))


def test_case1_resonances(frf_case1):
    """R1, R3: static 38.1 / 126.4 Hz; moment 82.8 / 110.5 / 198.5 Hz, within 0.5 %."""
    static = np.concatenate([_peaks(frf_case1, "bearing_D_vy_static"),
                             _peaks(frf_case1, "bearing_D_vz_static")])
    np.testing.assert_allclose(np.sort(static), [38.1, 126.4], rtol=0.005)
    moment = np.concatenate([_peaks(frf_case1, "bearing_D_vz_moment"),
                             _peaks(frf_case1, "bearing_D_vy_moment")])
    np.testing.assert_allclose(np.sort(moment), [82.8, 110.5, 198.5], rtol=0.005)


def test_case1_no_axial_response_to_static_unbalance(frf_case1):
    """R2: the bearing housings do not move axially under static unbalance."""
    ref = np.abs(frf_case1.responses["bearing_D_vy_static"]).max()
    for side in "DN":
        assert np.abs(frf_case1.responses[f"bearing_{side}_vx_static"]).max() < 1e-12 * ref


def test_case1_drive_and_non_drive_side_identical(frf_case1):
    """R5: symmetric machine -> identical D and N bearing FRFs (magnitudes)."""
    for comp in ("vz", "vy", "vx"):
        for exc in ("static", "moment"):
            a = np.abs(frf_case1.responses[f"bearing_D_{comp}_{exc}"])
            b = np.abs(frf_case1.responses[f"bearing_N_{comp}_{exc}"])
            np.testing.assert_allclose(a, b, rtol=1e-9, atol=1e-15 * a.max())


def test_yaw_mode_four_actuators():
    """R11: pure yaw at ~18.6 Hz in 2*/3*, not damped by the vertical actuators; DE = NDE."""
    speeds = TWO_PI * np.arange(10.0, 30.0, 0.01)
    for case in ("foot_mount_case2_4act", "foot_mount_case3_4act"):
        frf = unbalance_frf(load_machine(case).loop, speeds)
        peaks = _peaks(frf, "bearing_D_vy_moment")
        assert np.min(np.abs(peaks - 18.6)) < 0.005 * 18.6
        np.testing.assert_allclose(np.abs(frf.responses["bearing_D_vy_moment"]),
                                   np.abs(frf.responses["bearing_N_vy_moment"]), rtol=1e-9)


def test_forces_and_stiff_element():
    """R10: zero force at the stiff element (NR); case-3 forces match the reference (8.3)."""
    frf = unbalance_frf(load_machine("foot_mount_case3").loop, TWO_PI * np.array([10.0, 80.0, 250.0]))
    for exc in ("static", "moment"):
        assert not np.any(frf.responses[f"actuator_NR_fz_{exc}"])
    ref = {"static": [[65.2, 44.3, 65.7], [84.8, 70.3, 73.1], [86.6, 88.1, 88.0]],
           "moment": [[61.8, 61.7, 53.3], [74.0, 89.1, 80.3], [95.5, 94.1, 94.9]]}
    for exc, rows in ref.items():
        got = np.array([frf.db(f"actuator_{f}_fz_{exc}") for f in ("DL", "DR", "NL")]).T
        np.testing.assert_allclose(got, rows, atol=0.06)
    open_frf = unbalance_frf(load_machine("foot_mount_case2").loop, TWO_PI * np.array([10.0, 80.0]))
    assert not np.any(open_frf.responses["actuator_DL_fz_static"])


def test_spot_values_reference():
    """Digest 8.3 spot values (dB) at 10/20/38.1/50/80/126.4/200 Hz."""
    f = np.array([10, 20, 38.1, 50, 80, 126.4, 200])
    ref = {("foot_mount_case1", "bearing_D_vz_static"): [-87.27, -69.04, -51.64, -43.91, -28.70, 6.74, -12.81],
           ("foot_mount_case1", "bearing_D_vy_static"): [-65.89, -45.65, -3.72, -21.83, -23.02, -20.49, -16.79],
           ("foot_mount_case2", "bearing_D_vz_static"): [-27.15, -31.83, -28.07, -25.99, -20.56, -28.89, -18.23],
           ("foot_mount_case3", "bearing_D_vz_static"): [-44.41, -33.15, -28.68, -26.26, -20.69, -28.69, -18.26],
           ("foot_mount_case2", "bearing_D_vy_moment"): [-46.99, -1.95, -18.75, -17.83, -14.86, -11.10, -6.71],
           ("foot_mount_case3", "bearing_D_vy_moment"): [-39.80, -12.13, -18.87, -17.88, -14.88, -11.10, -6.71]}
    for (case, key), values in ref.items():
        frf = unbalance_frf(load_machine(case).loop, TWO_PI * f)
        np.testing.assert_allclose(frf.db(key), values, atol=0.011)


def test_control_lowers_low_speed_peaks():
    """R9: for f_r <= 80 Hz every bearing channel's maximum is lower in case 3 than in case 2."""
    speeds = TWO_PI * np.arange(1.0, 80.0, 0.02)
    f2 = unbalance_frf(load_machine("foot_mount_case2").loop, speeds)
    f3 = unbalance_frf(load_machine("foot_mount_case3").loop, speeds)
    for key in f2.responses:
        if key.startswith("bearing_"):
            assert f3.db(key).max() < f2.db(key).max() - 4.9, key
