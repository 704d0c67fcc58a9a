"""Order tracking: 1x phasors per unit unbalance against exact synthetic signals, against an
unbalance-driven oscillator integrated with scipy (analytic steady state as reference), and
through a bag round trip."""
import numpy as np
import pytest
from scipy.integrate import solve_ivp

from rotor_avc.analysis import order_tracking as ot
from rotor_avc.bag import BagReader, topics as T, write_bag
from rotor_avc.errors import ModelError

FS = 5000.0


def stepped_run(speeds_hz, dwell_s):
    n = int(dwell_s * FS)
    t = np.arange(n * len(speeds_hz)) / FS
    w = np.repeat(2 * np.pi * np.asarray(speeds_hz), n)
    theta = np.concatenate([[0.0], np.cumsum(w[:-1] / FS)])
    return t, w, theta


@pytest.mark.parametrize("seed", [0, 1, 2])
def test_stepped_recovers_known_phasors_with_offset(seed):
    rng = np.random.default_rng(seed)
    speeds = np.sort(rng.uniform(5, 240, 5))
    t, w, theta = stepped_run(speeds, 1.0)
    y_true = rng.standard_normal(5) + 1j * rng.standard_normal(5)
    u = 1e-3 * np.exp(1j * rng.uniform(-np.pi, np.pi))
    step = np.repeat(np.arange(5), int(FS))
    y = np.real(y_true[step] * u * np.exp(1j * theta)) + 100 * rng.standard_normal()   # offset
    track = ot.stepped_speed(t, theta, w, {"y": y, "2y": 2 * y}, unbalance=u)
    np.testing.assert_allclose(track.speed_hz, speeds, rtol=1e-9)
    err = np.abs(track.phasors["y"] / y_true - 1)
    assert np.all(err < 2.0 / track.samples), (err, track.samples)      # < one sample's share
    np.testing.assert_allclose(track.phasors["2y"], 2 * track.phasors["y"])
    assert np.all(track.revolutions >= 4) and np.all(track.time_s > 0)


def sdof_stepped(m, c, k, u, speeds_hz, dwell_s):
    """Unbalance force Re{u W^2 e^{j theta}} on m x'' + c x' + k x, from rest (solve_ivp)."""
    t, w, theta = stepped_run(speeds_hz, dwell_s)
    n = int(dwell_s * FS)
    x0, out = np.zeros(2), []
    for i, f in enumerate(speeds_hz):
        W, th0, seg = 2 * np.pi * f, theta[i * n], t[i * n:(i + 1) * n]

        def rhs(tt, s):
            force = np.real(u * W**2 * np.exp(1j * (th0 + W * (tt - seg[0]))))
            return [s[1], (force - c * s[1] - k * s[0]) / m]
        t_end = seg[-1] + 1 / FS
        sol = solve_ivp(rhs, (seg[0], t_end), x0, method="DOP853", rtol=1e-10, atol=1e-14,
                        t_eval=np.append(seg, t_end))
        out.append(sol.y[:, :-1])
        x0 = sol.y[:, -1]
    x, v = np.concatenate(out, axis=1)
    return t, w, theta, x, v


def test_stepped_oscillator_matches_analytic_steady_state():
    m, k, zeta = 10.0, 4e5, 0.05
    c = 2 * zeta * np.sqrt(k * m)                 # decay rate zeta*wn = 10/s
    u = 1e-3 * np.exp(0.7j)
    fn = np.sqrt(k / m) / (2 * np.pi)
    speeds = np.array([12.3, 0.97 * fn, fn, 47.9])
    t, w, theta, x, v = sdof_stepped(m, c, k, u, speeds, 1.6)
    track = ot.stepped_speed(t, theta, w, {"x": x, "v": v}, unbalance=u, settle_s=1.0)
    W = 2 * np.pi * speeds
    H = W**2 / (k - m * W**2 + 1j * c * W)        # displacement per unit unbalance (m/(kg m))
    for name, ref in (("x", H), ("v", 1j * W * H)):
        ratio = track.phasors[name] / ref
        assert np.all(np.abs(20 * np.log10(np.abs(ratio))) < 0.01), ratio
        assert np.all(np.abs(np.degrees(np.angle(ratio))) < 0.05), ratio


def test_run_up_equals_stepped_at_constant_speed_and_tracks_a_slow_sweep():
    t, w, theta = stepped_run([37.3], 2.0)
    y = np.real((0.3 - 0.2j) * np.exp(1j * theta))
    ru = ot.run_up(t, theta, {"y": y}, revolutions=8)
    np.testing.assert_allclose(ru.phasors["y"], 0.3 - 0.2j, rtol=2.0 / ru.samples.min())
    np.testing.assert_allclose(ru.speed_hz, 37.3, rtol=1e-9)
    # slow linear sweep 20 -> 40 Hz in 20 s (frequency change within a window <= 2 %) with a
    # smooth response Y(Omega): quasi-stationary, so the error is the sampling bound again
    t = np.arange(int(20 * FS)) / FS
    theta = 2 * np.pi * (20 * t + 0.5 * t**2)
    Y = lambda fr: 1 / (1 + 1j * fr / 40.0) ** 2      # noqa: E731
    y = np.real(Y(20 + t) * np.exp(1j * theta))
    ru = ot.run_up(t, theta, {"y": y}, revolutions=8)
    assert ru.speed_hz[0] < 21 and ru.speed_hz[-1] > 39
    err = np.abs(ru.phasors["y"] / Y(ru.speed_hz) - 1)
    assert np.all(err < 2.0 / ru.samples), err


def test_order_tracking_through_a_bag(tmp_path):
    """Joint state + a foot signal written to a bag and read back give the same phasors."""
    m, k, c, u = 10.0, 4e5, 200.0, 2e-3
    t, w, theta, x, v = sdof_stepped(m, c, k, u, [20.0, 35.0], 1.2)
    path = write_bag(tmp_path / "run.mcap",
                     [T.joint_state(t, theta, w), T.foot_acceleration("DL", t, v)],
                     {"machine": {"model": "sdof"}, "unbalance": {"static": u}})
    with BagReader(path, require_config=True) as bag:
        js = bag.series("/avc/rotor/joint_state")
        acc = bag.series("/avc/foot/DL/acceleration")
        u_bag = bag.config["unbalance"]["static"]
    from_bag = ot.stepped_speed(js.time_s, js["position[0]"], js["velocity[0]"],
                                {"v": acc["accel.linear.z"]}, unbalance=u_bag)
    direct = ot.stepped_speed(t, theta, w, {"v": v}, unbalance=u)
    np.testing.assert_allclose(from_bag.phasors["v"], direct.phasors["v"], rtol=1e-12)
    np.testing.assert_allclose(from_bag.speed_rad_s, direct.speed_rad_s, rtol=1e-12)


def test_a_wrapped_angle_is_refused_not_unwrapped():
    """Unwrapping across gaps drops revolutions; the tracker takes counted angles only."""
    t, w, theta = stepped_run([50.0], 1.0)
    y = np.cos(theta + 0.4)
    wrapped = np.angle(np.exp(1j * theta))
    with pytest.raises(ModelError, match="wrapped angle"):
        ot.stepped_speed(t, wrapped, w, {"y": y})
    np.testing.assert_allclose(np.angle(ot.stepped_speed(t, theta, w, {"y": y}).phasors["y"]),
                               0.4, atol=1e-3)


@pytest.mark.parametrize("call, problem", [
    (lambda t, w, th, y: ot.stepped_speed(t, th, w, {"y": y}, unbalance=0), "unbalance amplitude"),
    (lambda t, w, th, y: ot.stepped_speed(t, th, w, {"y": y[:-1]}), "signal 'y' has shape"),
    (lambda t, w, th, y: ot.stepped_speed(t, th, w, {"y": y}, min_revolutions=1000),
     "no constant-speed dwell with 1000 whole revolutions"),
    (lambda t, w, th, y: ot.stepped_speed(t, th, w, {}), "no signals"),
    (lambda t, w, th, y: ot.run_up(t, -th, {"y": y}), "must increase"),
    (lambda t, w, th, y: ot.run_up(t[::-1], th, {"y": y}), "strictly increasing"),
])
def test_errors_name_the_problem(call, problem):
    t, w, theta = stepped_run([20.0, 30.0], 0.5)
    with pytest.raises(ModelError, match=problem):
        call(t, w, theta, np.cos(theta))


def test_drift_tells_a_settled_dwell_from_a_transient():
    """The drift of a dwell is |Y(second half) - Y(first half)| / |Y|: ~0 in steady state, the
    envelope change of a decaying transient otherwise."""
    from rotor_avc.analysis.order_tracking import stepped_speed
    fs, f = 2000.0, 10.0
    t = np.arange(int(4 * fs)) / fs
    theta = 2 * np.pi * f * t
    speed = np.full_like(t, 2 * np.pi * f)
    steady = np.cos(theta + 0.3)
    sigma = 0.5                                      # 1/s: a lightly damped mode still ringing
    ringing = steady + 0.5 * np.exp(-sigma * t) * np.cos(2 * np.pi * f * 1.01 * t)
    track = stepped_speed(t, theta, speed, {"steady": steady, "ringing": ringing})
    assert track.drift["steady"][0] < 1e-9
    assert track.drift["ringing"][0] > 0.02
