"""The layout holds: every import of the package's own modules — at module level, inside a
function, under ``if TYPE_CHECKING`` — goes down the layer map ``FLOORS`` or stays on its floor;
the module graph (function-local imports included) has no cycle, nor have the packages of one
floor; every module listed in ARCHITECTURE.md exists (and every module is listed); every
"DESIGN.md §N" the code cites exists.

The checker works on source text (``layer_problems``), so the tests below prove by mutation that
it catches an upward import written inside a function, at module level, under TYPE_CHECKING or
in a relative form, and a cycle.
"""

from __future__ import annotations

import ast
import re
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
PACKAGE = ROOT / "src" / "incandescent"
TOP = "incandescent"

#: The package's floors, bottom to top (DESIGN.md §2). A module may import modules of its own
#: floor or of a floor below, never of one above; on one floor, without a cycle (modules, and
#: the packages of the floor). Each name is a top-level module or package of ``incandescent``;
#: ``__init__`` is the package ``incandescent`` itself.
FLOORS: tuple[tuple[str, ...], ...] = (
    # ground: no domain — validators, SI constants, memory/sample limits, the host thread pool,
    # Dr.Jit loading, the version
    ("_validate", "constants", "budget", "_parallel", "_jit", "_version"),
    # domains that need only the ground: cameras, colour spaces, file formats, Volume
    ("camera", "colorimetry", "io", "volume"),
    # Planck, CMFs and line tables (tables read through io; chromaticities from colorimetry);
    # the display pipeline (colorimetry; a Planckian white from spectra); the fire solver
    # (Volumes out, frame files through io; its settings files parsed by io.textfiles)
    ("spectra", "imaging", "simulation"),
    # emission models (over spectra); the ready-made scenes (volumes, cameras, display settings);
    # a camera's sensor (its spectral curves on the CIE grid, an observer of its own)
    ("emission", "scenes", "sensor"),
    # render(): models, volume and camera → HDRImage (backends, and soon renderer/integrators/)
    ("renderer",),
    # products over the renderer: scene files → Volume and settings, sequences, the public API,
    # saving images, a camera's raw exposure, temperature from raw images, gradients of renders
    ("config", "animation", "api", "output", "photograph", "pyrometry", "inverse", "dcc"),
    # frames as Dask tasks (through api and config)
    ("cluster",),
    # entry points: the benchmark, a fire's frames rendered (simulation over animation and
    # cluster), the interactive viewer (a web server over api and config), the typer app, the
    # package's own namespace
    ("benchmark", "fire_video", "viewer", "cli", "__init__"),
)


@dataclass(frozen=True)
class Import:
    """One import statement's target in module ``source``: ``target`` is a module of the package
    where one matches, else the imported name; ``where`` says in which scope it sits."""

    source: str
    target: str
    line: int
    where: str

    def __str__(self) -> str:
        return f"{self.source}:{self.line} ({self.where}) imports {self.target}"


def module_name(relative: str) -> str:
    """``volume/grid.py`` → ``incandescent.volume.grid``; ``volume/__init__.py`` →
    ``incandescent.volume``; ``__init__.py`` → ``incandescent``."""
    parts = (TOP, *Path(relative).with_suffix("").parts)
    return ".".join(parts[:-1] if parts[-1] == "__init__" else parts)


def _raw_imports(name: str, is_package: bool, source: str) -> list[tuple[str, int, str]]:
    """Every name imported in ``source`` as (absolute dotted name, line, scope), walking into
    functions, classes, ``if TYPE_CHECKING`` and every other block: ``import a.b`` gives
    ``a.b``, ``from a import b`` gives ``a.b`` (a module or a name in ``a``), relative forms are
    made absolute; ``importlib.import_module`` and ``__import__`` of a literal name count too."""
    package = name if is_package else name.rpartition(".")[0]
    found: list[tuple[str, int, str]] = []

    def absolute(module: str | None, level: int) -> str:
        if not level:
            return module or ""
        base = ".".join(package.split(".")[: len(package.split(".")) - level + 1])
        return f"{base}.{module}" if module else base

    def visit(node: ast.AST, where: str) -> None:
        if isinstance(node, ast.Import):
            found.extend((alias.name, node.lineno, where) for alias in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = absolute(node.module, node.level)
            found.extend((f"{base}.{alias.name}", node.lineno, where) for alias in node.names)
        elif (
            isinstance(node, ast.Call)
            and (getattr(node.func, "attr", None) or getattr(node.func, "id", None))
            in ("import_module", "__import__")
            and node.args
            and isinstance(node.args[0], ast.Constant)
            and isinstance(node.args[0].value, str)
        ):
            found.append((node.args[0].value, node.lineno, where))
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
            where = f"in function {node.name}"
        elif isinstance(node, ast.ClassDef):
            where = f"in class {node.name}"
        elif isinstance(node, ast.If) and "TYPE_CHECKING" in ast.dump(node.test):
            where = "under TYPE_CHECKING"
        for child in ast.iter_child_nodes(node):
            visit(child, where)

    visit(ast.parse(source), "module level")
    return found


def module_graph(sources: Mapping[str, str]) -> dict[str, list[Import]]:
    """Each module of ``sources`` (source text by path relative to the package, e.g.
    ``volume/grid.py``) → its imports of the package, self-imports left out. A target is the
    longest module of ``sources`` that the imported name starts with (``from a import b``: the
    module ``a.b`` if there is one, else ``a``), or the name itself when no module matches."""
    names = {module_name(path): path for path in sources}

    def resolve(imported: str) -> str:
        parts = imported.split(".")
        while len(parts) > 1 and ".".join(parts) not in names:
            parts.pop()
        return ".".join(parts) if ".".join(parts) in names else imported

    graph: dict[str, list[Import]] = {}
    for name, path in names.items():
        raw = _raw_imports(name, path.endswith("__init__.py"), sources[path])
        mine = [(resolve(n), line, where) for n, line, where in raw if n.split(".")[0] == TOP]
        imports = [Import(name, t, line, where) for t, line, where in mine if t != name]
        graph[name] = list(dict.fromkeys(imports))  # ``from a import b, c``: one edge to ``a``
    return graph


def component(module: str) -> str:
    """The top-level name a module belongs to: ``incandescent.volume.grid`` → ``volume``,
    ``incandescent`` → ``__init__``."""
    return module.split(".")[1] if "." in module else "__init__"


def floor_of(floors: tuple[tuple[str, ...], ...] = FLOORS) -> dict[str, int]:
    return {name: level for level, names in enumerate(floors) for name in names}


def upward_imports(
    graph: Mapping[str, list[Import]], floors: tuple[tuple[str, ...], ...] = FLOORS
) -> list[str]:
    """Every import that runs up the floors, or from or to a name the floors do not place."""
    level = floor_of(floors)
    problems = []
    for imports in graph.values():
        for imp in imports:
            here, there = component(imp.source), component(imp.target)
            if here not in level or there not in level:
                unplaced = here if here not in level else there
                problems.append(f"{imp}: {unplaced!r} is on no floor of the layer map")
            elif level[there] > level[here]:
                problems.append(
                    f"{imp}: up from {here} (floor {level[here]}) to {there} (floor {level[there]})"
                )
    return problems


def cycles(graph: Mapping[str, set[str]]) -> list[list[str]]:
    """The strongly connected components of more than one node (each a cycle or several), each
    sorted, in sorted order (Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    found: list[list[str]] = []

    def visit(node: str) -> None:
        index[node] = low[node] = len(index)
        stack.append(node)
        on_stack.add(node)
        for nxt in sorted(graph.get(node, ())):
            if nxt not in index:
                visit(nxt)
                low[node] = min(low[node], low[nxt])
            elif nxt in on_stack:
                low[node] = min(low[node], index[nxt])
        if low[node] == index[node]:
            members = []
            while True:
                member = stack.pop()
                on_stack.discard(member)
                members.append(member)
                if member == node:
                    break
            if len(members) > 1:
                found.append(sorted(members))

    for node in sorted(graph):
        if node not in index:
            visit(node)
    return sorted(found)


def layer_problems(
    sources: Mapping[str, str], floors: tuple[tuple[str, ...], ...] = FLOORS
) -> list[str]:
    """Everything wrong with the layering of ``sources``: upward imports, module cycles, cycles
    between the packages of one floor. Empty when the layout holds."""
    graph = module_graph(sources)
    problems = upward_imports(graph, floors)
    modules = {name: {imp.target for imp in imports} for name, imports in graph.items()}
    problems += [f"module cycle: {' ↔ '.join(c)}" for c in cycles(modules)]
    level = floor_of(floors)
    packages: dict[str, set[str]] = {}
    for name, targets in modules.items():
        for target in targets:
            here, there = component(name), component(target)
            if here != there and level.get(here, -1) == level.get(there, -2):
                packages.setdefault(here, set()).add(there)
    problems += [
        f"cycle between the packages of one floor: {' ↔ '.join(c)}" for c in cycles(packages)
    ]
    return problems


def package_sources() -> dict[str, str]:
    """The package's source text by path relative to it (``volume/grid.py``)."""
    return {str(p.relative_to(PACKAGE)): p.read_text() for p in sorted(PACKAGE.rglob("*.py"))}


def test_no_import_runs_up_the_floors_and_no_cycle():
    graph = module_graph(package_sources())
    imports = [imp for found in graph.values() for imp in found]
    assert len(imports) > 300  # the walk sees the imports ...
    assert sum(imp.where != "module level" for imp in imports) > 50  # ... and the local ones
    problems = layer_problems(package_sources())
    assert problems == [], f"{len(problems)} upward arrows or cycles:\n" + "\n".join(problems)


def test_every_name_of_the_package_is_on_one_floor_and_the_floors_name_only_those():
    names = [name for floor in FLOORS for name in floor]
    assert len(names) == len(set(names)), "a name on two floors"
    present = {component(module_name(path)) for path in package_sources()}
    assert set(names) == present


#: Mutations of the real package that the checker must report: (path, text added, what the
#: report must say).
MUTATIONS = [
    pytest.param(
        "volume/grid.py",
        "\n\ndef _probe():\n    from incandescent.cli import app\n\n    return app\n",
        "(in function _probe) imports incandescent.cli: up from volume (floor 1) to cli",
        id="function-local",
    ),
    pytest.param(
        "volume/grid.py",
        "\nfrom incandescent.cli import app  # noqa\n",
        "(module level) imports incandescent.cli: up from volume",
        id="module-level",
    ),
    pytest.param(
        "volume/grid.py",
        "\nif TYPE_CHECKING:\n    from incandescent.renderer.film import HDRImage\n",
        "(under TYPE_CHECKING) imports incandescent.renderer.film: up from volume",
        id="type-checking",
    ),
    pytest.param(
        "volume/grid.py",
        "\n\nclass _Probe:\n    def m(self):\n        import incandescent.config.schema\n",
        "(in function m) imports incandescent.config.schema: up from volume",
        id="import-a.b-in-a-method",
    ),
    pytest.param(
        "volume/grid.py",
        "\n\ndef _probe():\n    from ..renderer import film\n",
        "imports incandescent.renderer.film: up from volume",
        id="relative-parent",
    ),
    pytest.param(
        "io/images.py",
        "\n\ndef _probe():\n    from .. import api\n",
        "imports incandescent.api: up from io",
        id="relative-from-dots-import",
    ),
    pytest.param(
        "spectra/cmf.py",
        "\n\ndef _probe():\n    importlib.import_module('incandescent.emission.base')\n",
        "imports incandescent.emission.base: up from spectra",
        id="import_module",
    ),
    pytest.param(
        "_validate.py",
        "\n\ndef _probe():\n    from incandescent import Camera\n",
        "imports incandescent: up from _validate (floor 0) to __init__",
        id="the-package-itself",
    ),
]


@pytest.mark.parametrize(("path", "added", "reported"), MUTATIONS)
def test_an_upward_import_added_to_the_package_is_reported(path, added, reported):
    sources = package_sources()
    sources[path] += added
    name = module_name(path)
    problems = layer_problems(sources)
    assert [p for p in problems if p.startswith(f"{name}:") and reported in p], problems


def test_an_upward_import_in_a_synthetic_module_is_reported():
    sources = {
        "volume/grid.py": "def f():\n    from incandescent.cli import app\n",
        "cli.py": "",
    }
    assert layer_problems(sources) == [
        "incandescent.volume.grid:2 (in function f) imports incandescent.cli: up from volume "
        "(floor 1) to cli (floor 7)"
    ]
    assert layer_problems({"volume/grid.py": "from incandescent.cli import app\n"}) == [
        "incandescent.volume.grid:1 (module level) imports incandescent.cli.app: up from volume "
        "(floor 1) to cli (floor 7)"
    ]
    assert layer_problems({"cli.py": "from incandescent.volume.grid import Volume\n"}) == []


def test_a_module_off_the_map_is_reported():
    problems = layer_problems({"newthing/x.py": "from incandescent import _validate\n"})
    assert problems == [
        "incandescent.newthing.x:1 (module level) imports incandescent._validate: 'newthing' is "
        "on no floor of the layer map"
    ]


def test_a_cycle_through_function_local_imports_is_reported():
    sources = package_sources()
    sources["camera/camera.py"] += (
        "\n\ndef _probe():\n    from incandescent.colorimetry import xyz\n"
    )
    sources["colorimetry/xyz.py"] += (
        "\n\ndef _probe():\n    from incandescent.camera import camera\n"
    )
    problems = layer_problems(sources)
    assert "module cycle: incandescent.camera.camera ↔ incandescent.colorimetry.xyz" in problems
    assert "cycle between the packages of one floor: camera ↔ colorimetry" in problems
    assert len(problems) == 2  # both arrows stay on floor 1: not upward


def test_a_cycle_between_packages_of_one_floor_is_reported_without_a_module_cycle():
    sources = {
        "io/images.py": "def f():\n    from incandescent.volume.slabs import workers\n",
        "volume/slabs.py": "",
        "volume/assemble.py": "from incandescent.io.images import f\n",
    }
    assert layer_problems(sources) == ["cycle between the packages of one floor: io ↔ volume"]


def test_the_cycle_check_finds_a_cycle():
    assert cycles({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == [["a", "b", "c"]]
    assert cycles({"a": {"b"}, "b": set(), "c": {"d"}, "d": {"c"}}) == [["c", "d"]]
    assert cycles({"a": {"b"}, "b": set()}) == []


def test_architecture_lists_every_module_and_only_modules_that_exist():
    text = (ROOT / "ARCHITECTURE.md").read_text().split("## Modules", 1)[1].split("\n## ", 1)[0]
    rows = [line for line in text.splitlines() if line.startswith("| `")]
    listed = {m for row in rows for m in re.findall(r"`((?:[a-z_0-9]+/)*[a-z_0-9]+\.py)`", row)}
    on_disk = {
        str(p.relative_to(PACKAGE)) for p in PACKAGE.rglob("*.py") if p.name != "__init__.py"
    }
    assert listed - on_disk == set(), "listed in ARCHITECTURE.md but missing"
    assert on_disk - listed == set(), "modules missing from ARCHITECTURE.md"


def test_design_sections_the_code_cites_exist():
    design = (ROOT / "docs" / "design" / "DESIGN.md").read_text()
    sections = set(re.findall(r"^## (\d+)\. ", design, flags=re.M))
    cited = set()
    for path in list(PACKAGE.rglob("*.py")) + list((ROOT / "tests").rglob("*.py")):
        cited |= set(re.findall(r"DESIGN(?:\.md)? §(\d+)", path.read_text()))
    assert cited and cited <= sections, f"cited {sorted(cited)}, present {sorted(sections)}"


def _floors_in(text: str) -> list[set[str]]:
    """The floors a page lists: one bullet per floor, its module names in backticks."""
    names = {name for floor in FLOORS for name in floor} - {"__init__"}
    floors = []
    for line in text.splitlines():
        if line.startswith("- "):
            floors.append({n for n in re.findall(r"`([a-z_]+)`", line) if n in names})
        elif floors and line.startswith("  "):
            floors[-1] |= {n for n in re.findall(r"`([a-z_]+)`", line) if n in names}
        elif floors and not line.strip():
            break
    return floors


def test_design_lists_the_floors_the_test_keeps():
    """DESIGN.md §2 names the same floors, in the same order, as ``FLOORS``."""
    design = (ROOT / "docs" / "design" / "DESIGN.md").read_text()
    section = design.split("## 2. Layout", 1)[1].split("\n## ", 1)[0]
    listed = _floors_in(section.split("Bottom\nto top:", 1)[1].lstrip("\n"))
    assert listed == [set(floor) - {"__init__"} for floor in FLOORS]


def test_architecture_names_the_floors_in_order():
    """ARCHITECTURE.md's import rule names the floors in ``FLOORS``'s order (arrows between)."""
    text = (ROOT / "ARCHITECTURE.md").read_text()
    rule = text.split("Imports go down the floors", 1)[1].split("— or stay", 1)[0]
    names = {name for floor in FLOORS for name in floor}
    listed = [
        {n for n in re.findall(r"`([a-z_]+)`", part) if n in names} for part in rule.split("→")
    ]
    assert listed == [set(floor) - {"__init__"} for floor in FLOORS]
