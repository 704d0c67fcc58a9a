"""The import graph of rotor_avc (read with the standard library's ast, every import statement
including those inside functions) has no cycle and no arrow against the layer order that
docs/DESIGN.md documents."""
import ast
import re
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "rotor_avc"


def module_name(path: Path) -> str:
    parts = list(path.relative_to(ROOT).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def import_graph() -> dict[str, set[str]]:
    """module -> the rotor_avc modules it imports (``from pkg import mod`` counts as ``mod``)."""
    files = {module_name(p): p for p in PACKAGE.rglob("*.py")}
    graph = {}
    for name, path in files.items():
        package = name if path.name == "__init__.py" else name.rpartition(".")[0]
        targets = set()
        for node in ast.walk(ast.parse(path.read_text(), str(path))):
            if isinstance(node, ast.Import):
                targets |= {a.name for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                base = node.module or ""
                if node.level:
                    parent = package.split(".")[:len(package.split(".")) - node.level + 1]
                    base = ".".join(parent + ([node.module] if node.module else []))
                subs = {f"{base}.{a.name}" for a in node.names} & files.keys()
                targets |= subs or {base}
        graph[name] = {t for t in targets if t in files and t != name}
    return graph


def documented_layers() -> list[str]:
    """The rooms in docs/DESIGN.md's layer line, lowest first."""
    text = (ROOT / "docs" / "DESIGN.md").read_text()
    line = re.search(r"^Layers \(lowest first\): (.+)$", text, re.MULTILINE)
    assert line, "docs/DESIGN.md lost its `Layers (lowest first): a → b → ...` line"
    return [room.strip(" `.") for room in line.group(1).split("→")]


def room(module: str) -> str:
    parts = module.split(".")
    return "rotor_avc" if len(parts) == 1 else parts[1]


def test_layer_order_names_every_room_once():
    layers = documented_layers()
    rooms = {room(m) for m in import_graph()}
    assert len(layers) == len(set(layers))
    assert set(layers) == rooms, f"rooms not in the documented order: {rooms ^ set(layers)}"


def test_no_import_points_up_the_layers():
    rank = {name: i for i, name in enumerate(documented_layers())}
    upward = sorted(f"{a} -> {b}" for a, targets in import_graph().items() for b in targets
                    if rank[room(b)] > rank[room(a)])
    assert not upward, "imports against the layer order:\n" + "\n".join(upward)


def test_no_import_cycle():
    graph = import_graph()
    state, cycles = {}, []

    def visit(node, stack):
        state[node] = "open"
        for nxt in sorted(graph[node]):
            if state.get(nxt) == "open":
                cycles.append(" -> ".join(stack[stack.index(nxt):] + [nxt]))
            elif nxt not in state:
                visit(nxt, stack + [nxt])
        state[node] = "done"

    for node in sorted(graph):
        if node not in state:
            visit(node, [node])
    assert not cycles, "import cycles:\n" + "\n".join(cycles)



def test_models_import_only_numpy_scipy_and_their_errors():
    """The physics builders take numbers: rotor_avc.models imports numpy, scipy, the standard
    library, its own room and rotor_avc.errors -- no config views (those are model_config/)."""
    stdlib = {"__future__", "dataclasses", "functools", "math", "typing"}
    found = set()
    for path in (PACKAGE / "models").rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                found |= {(path.name, a.name) for a in node.names}
            elif isinstance(node, ast.ImportFrom):
                name = "rotor_avc." + "models." * (node.level == 1) + (node.module or "") \
                    if node.level else node.module
                found.add((path.name, name))
    wrong = sorted(f"{file}: {name}" for file, name in found
                   if name.split(".")[0] not in stdlib | {"numpy", "scipy"}
                   and not name.startswith(("rotor_avc.models.", "rotor_avc.errors")))
    assert not wrong, "models/ imports beyond numpy/scipy:\n" + "\n".join(wrong)


def test_runtime_dependencies_are_what_runtime_code_imports():
    """install_requires lists exactly the third-party packages rotor_avc imports (ROS 2 comes
    from the distribution or the `ros` extra; the test-only packages are in the `test` extra;
    dask.distributed, imported only where a study runs on a cluster, is the `cluster` extra)."""
    ros = {"rclpy", "rcl_interfaces", "builtin_interfaces", "diagnostic_msgs", "geometry_msgs",
           "rosgraph_msgs", "sensor_msgs", "std_msgs"}
    distribution = {"yaml": "PyYAML"}                  # import name -> PyPI name, where they differ
    imported = set()
    for path in PACKAGE.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.Import):
                imported |= {a.name.split(".")[0] for a in node.names}
            elif isinstance(node, ast.ImportFrom) and not node.level:
                imported.add(node.module.split(".")[0])
    third_party = imported - set(sys.stdlib_module_names) - ros - {"rotor_avc"}
    setup = ast.parse((ROOT / "setup.py").read_text())
    call = next(n for n in ast.walk(setup) if isinstance(n, ast.Call)
                and getattr(n.func, "id", "") == "setup")
    requires = next(k.value for k in call.keywords if k.arg == "install_requires")
    names = {re.split(r"[<>=\[ ]", ast.literal_eval(e))[0] for e in requires.elts} - {"setuptools"}
    extras = ast.literal_eval(next(k.value for k in call.keywords if k.arg == "extras_require"))
    cluster = {re.split(r"[<>=\[ ]", e)[0] for e in extras["cluster"]}
    assert {distribution.get(m, m) for m in third_party} == names | cluster


#: the rooms that compute: they read configurations through rotor_avc.section, never YAML
COMPUTING_ROOMS = ("settings", "blocks", "models", "model_config", "control", "closed_loop",
                   "sim", "balancing", "studies", "analysis", "harmonic")
YAML_LAYER = ("yaml", "rotor_avc.yaml_reading", "rotor_avc.config")


def test_the_computing_rooms_never_import_the_yaml_layer():
    """Configuration files are loaded in the composition (rotor_avc.config, machine, scenario
    and the commands); the rooms that compute take the loaded mapping as a Section, typed
    settings or numbers."""
    found = []
    for path in sorted(PACKAGE.rglob("*.py")):
        module = module_name(path)
        if room(module) not in COMPUTING_ROOMS:
            continue
        for node in ast.walk(ast.parse(path.read_text())):
            names = []
            if isinstance(node, ast.Import):
                names = [a.name for a in node.names]
            elif isinstance(node, ast.ImportFrom):
                base = module.rsplit(".", node.level)[0] if node.level else ""
                mod = (base + "." + node.module if node.level and node.module else
                       base if node.level else node.module)
                names = [mod] + [f"{mod}.{a.name}" for a in node.names]
            found += [f"{module}: {n}" for n in names
                      if any(n == y or n.startswith(y + ".") for y in YAML_LAYER)]
    assert not found, "the YAML layer imported by a computing room:\n" + "\n".join(found)
