"""``rotor-avc balance``: the command writes the time series and the plot, and bad scenarios give
one-line errors naming the field."""
import numpy as np
import yaml

from rotor_avc.cli import main
from rotor_avc.config import find_config

CONFIG = find_config("balancer_rigid_rotor")


def test_balance_rigid_rotor_writes_npz_and_plot(tmp_path, capsys):
    assert main(["balance", "balancer_rigid_rotor", "--out", str(tmp_path), "--duration-s",
                 "1.1"]) == 0
    data = np.load(tmp_path / "balance.npz")
    assert (tmp_path / "balance.png").stat().st_size > 10_000
    assert abs(data["t"][-1] - 1.1) < 1e-9
    assert round(float(data["switch_times"][0]), 4) == 2.9506
    assert np.all(data["rel_error"][-1] < 0.01)
    assert "mode1" in set(data["mode"])
    assert "t = 1.0000 s: mode1" in capsys.readouterr().out


def test_balance_refuses_zero_acceleration(tmp_path, capsys):
    cfg = yaml.safe_load(CONFIG.read_text())
    cfg["balancer"]["run_up"]["accel_rad_s2"] = 0.0
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(cfg))
    assert main(["balance", str(path), "--out", str(tmp_path)]) == 2
    assert "balancer.run_up.accel_rad_s2: must be > 0" in capsys.readouterr().err


def test_balance_refuses_plane_outside_rotor(tmp_path, capsys):
    cfg = yaml.safe_load(CONFIG.read_text())
    cfg["balancer"]["axial_position_m"] = 0.8
    path = tmp_path / "bad.yaml"
    path.write_text(yaml.safe_dump(cfg))
    assert main(["balance", str(path), "--out", str(tmp_path)]) == 2
    assert "balancer.axial_position_m" in capsys.readouterr().err
