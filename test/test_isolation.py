"""File paths in configs and bags are confined to what the user named: an ``include:`` outside
the including file's folder (and the package's config folder), and a rosbag2 ``metadata.yaml``
entry outside the bag's folder (absolute, ``..``, a symbolic link leading out), are refused in one
line without the file being opened or quoted; control characters in a config are refused in one
line naming the file and line. Test sessions are isolated from each other too: two never share a
ROS domain (test/conftest.py)."""
import builtins
import os
import shutil
import subprocess
import sys
from pathlib import Path

import pytest
import yaml

from rotor_avc.bag import BagError
from rotor_avc.bag.rosbag2 import open_bag
from rotor_avc.cli import main
from rotor_avc.config import find_config, load_config, load_yaml
from rotor_avc.errors import ConfigError

ROOT = Path(__file__).resolve().parents[1]
REFERENCE_BAG = ROOT / "bags" / "reference" / "case3_stepped.mcap"
SECRET = "hunter2-do-not-print"


@pytest.fixture
def opened(monkeypatch):
    """The absolute paths of every file opened from now on."""
    paths, real_open = [], builtins.open

    def recording_open(file, *args, **kwargs):
        if isinstance(file, (str, os.PathLike)):
            paths.append(Path(os.path.abspath(file)))
        return real_open(file, *args, **kwargs)

    monkeypatch.setattr(builtins, "open", recording_open)
    return paths


# -- include: ---------------------------------------------------------------------------------
@pytest.fixture
def layout(tmp_path):
    """``cfg/`` (the user's folder, with ``cfg/sub/``) and ``secret/creds.yaml`` beside it."""
    (tmp_path / "cfg" / "sub").mkdir(parents=True)
    (tmp_path / "secret").mkdir()
    secret = tmp_path / "secret" / "creds.yaml"
    secret.write_text(f"password: {SECRET}\n")
    (tmp_path / "cfg" / "link.yaml").symlink_to(secret)
    return tmp_path


@pytest.mark.parametrize("include", ["{secret}", "../secret/creds.yaml",
                                     "sub/../../secret/creds.yaml", "link.yaml", "/etc/shadow",
                                     "../secret/missing.yaml"])
def test_an_include_outside_the_allowed_folders_is_refused_unread(layout, opened, include):
    secret = layout / "secret" / "creds.yaml"
    cfg = layout / "cfg" / "a.yaml"
    cfg.write_text("model: foot_mount\ninclude: " + include.format(secret=secret) + "\n")
    with pytest.raises(ConfigError) as info:
        load_yaml(cfg)
    text = str(info.value)
    assert text.startswith(f"{cfg}: line 2: include: included file ")
    assert "is outside the folders a config may include from" in text and "\n" not in text
    assert SECRET not in text and "root:" not in text
    assert not any(p.parent == secret.parent or p == Path("/etc/shadow") for p in opened), opened


def test_the_command_line_refuses_it_in_one_line(layout, capsys):
    cfg = layout / "cfg" / "a.yaml"
    cfg.write_text("include: /etc/shadow\n")
    assert main(["poles", str(cfg)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "/etc/shadow" in err[0] and "outside the folders" in err[0]
    assert "root:" not in err[0]


def test_includes_inside_the_folder_and_shipped_configs_load(layout):
    cfg = layout / "cfg"
    (cfg / "sub" / "part.yaml").write_text("simulation: {duration_s: 0.5}\n")
    (cfg / "sub" / "inner.yaml").symlink_to(cfg / "sub" / "part.yaml")
    (cfg / "a.yaml").write_text(f"include: [{find_config('scenario_case3_steady')}, "
                                "sub/inner.yaml]\n")
    data = load_yaml(cfg / "a.yaml")
    assert data["simulation"]["duration_s"] == 0.5 and "machine" in data
    assert load_config("scenario_case3_steady").section("simulation").number("duration_s") == 2.0


# -- control characters ---------------------------------------------------------------------------
@pytest.mark.parametrize("char", ["\x00", "\x01", "\x08", "\x0b", "\x1b", "\x7f", "\x9b"])
@pytest.mark.parametrize("where", ["value", "comment", "key"])
def test_control_characters_are_refused_naming_file_and_line(tmp_path, capsys, char, where):
    line = {"value": f"model: foot{char}mount", "comment": f"# a note{char}",
            "key": f"mo{char}del: foot_mount"}[where]
    cfg = tmp_path / "c.yaml"
    cfg.write_bytes(f"# machine\nsimulation: {{duration_s: 1.0}}\n{line}\n".encode())
    with pytest.raises(ConfigError) as info:
        load_yaml(cfg)
    assert str(info.value).startswith(f"{cfg}: line 3: control character U+{ord(char):04X}")
    assert main(["poles", str(cfg)]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and f"{cfg}: line 3: control character" in err[0]


def test_tab_newline_and_carriage_return_are_allowed(tmp_path):
    cfg = tmp_path / "crlf.yaml"
    cfg.write_bytes(b"# machine\r\nsimulation: {duration_s: 1.0}  #\tnote\r\nname: \"a\tb\"\r\n")
    assert load_yaml(cfg) == {"simulation": {"duration_s": 1.0}, "name": "a\tb"}


# -- rosbag2 metadata.yaml ------------------------------------------------------------------------
def _directory(root: Path, names, files=None) -> Path:
    """A rosbag2 directory ``root/bag`` with the reference bag as ``bag_0.mcap`` and a
    ``metadata.yaml`` listing ``names`` (and ``files`` entries, default: one per name)."""
    bag = root / "bag"
    bag.mkdir()
    shutil.copy(REFERENCE_BAG, bag / "bag_0.mcap")
    info = {"version": 9, "storage_identifier": "mcap", "relative_file_paths": list(names),
            "files": files if files is not None else [{"path": n} for n in names]}
    (bag / "metadata.yaml").write_text(yaml.safe_dump({"rosbag2_bagfile_information": info}))
    return bag


@pytest.fixture
def outside(tmp_path):
    """A valid bag outside the bag folder (so opening it would succeed)."""
    path = tmp_path / "elsewhere" / "other.mcap"
    path.parent.mkdir()
    shutil.copy(REFERENCE_BAG, path)
    return path


@pytest.mark.parametrize("kind", ["absolute", "dotdot", "symlink", "files_entry", "metadata"])
def test_a_bag_entry_outside_its_folder_is_refused_unread(tmp_path, outside, opened, capsys,
                                                           kind):
    if kind == "absolute":
        bag = _directory(tmp_path, [str(outside)])
    elif kind == "dotdot":
        bag = _directory(tmp_path, ["../elsewhere/other.mcap"])
    elif kind == "symlink":
        bag = _directory(tmp_path, ["link.mcap"])
        (bag / "link.mcap").symlink_to(outside)
    elif kind == "files_entry":
        bag = _directory(tmp_path, ["bag_0.mcap"], files=[{"path": str(outside)}])
    else:
        bag = _directory(tmp_path, ["bag_0.mcap"])
        real = outside.parent / "metadata.yaml"
        shutil.move(bag / "metadata.yaml", real)
        (bag / "metadata.yaml").symlink_to(real)
    with pytest.raises(BagError) as info:
        open_bag(bag)
    text = str(info.value)
    assert text.startswith(f"{bag / 'metadata.yaml'}: ") and "\n" not in text
    assert ("leads outside the bag's folder" in text if kind in ("dotdot", "symlink", "metadata")
            else "is an absolute path" in text)
    for command in (["bag", "info", str(bag)], ["bag", "check", str(bag)],
                    ["compare", str(bag), "--out", str(tmp_path / "report")]):
        assert main(command) == 2
        err = capsys.readouterr().err.strip().splitlines()
        assert len(err) == 1 and "metadata.yaml" in err[0], err
    assert not any(p.parent == outside.parent for p in opened), opened


def test_a_bag_listing_its_own_files_opens(tmp_path):
    with open_bag(_directory(tmp_path, ["bag_0.mcap"])) as bag:
        assert bag.message_count > 0


def test_two_test_sessions_never_share_a_ros_domain():
    """A second session given the same ROS_DOMAIN_ID (the Makefile's, CI's) while this one holds
    it takes another free domain; one given a free domain keeps it."""
    mine = int(os.environ["ROS_DOMAIN_ID"])
    probe = ("import os, sys; sys.path.insert(0, {test!r}); import conftest; "
             "print(os.environ['ROS_DOMAIN_ID'])")
    test_dir = os.path.dirname(os.path.abspath(__file__))
    domains = {}
    for given in (str(mine), "7"):
        env = {**os.environ, "ROS_DOMAIN_ID": given}
        out = subprocess.run([sys.executable, "-c", probe.format(test=test_dir)], env=env,
                             capture_output=True, text=True, timeout=120, check=True)
        domains[given] = int(out.stdout.strip())
    assert domains[str(mine)] != mine and domains[str(mine)] in range(110, 200)
    assert domains["7"] == 7
