"""The code's layout: the engine never reaches the inspector, and no module imports one that imports it back."""
import ast
from pathlib import Path

import networkx as nx

ROOT = Path(__file__).resolve().parent.parent


def _imports(package: str) -> nx.DiGraph:
    """module -> every module of skelcore or app it imports, at the top or inside a function."""
    graph = nx.DiGraph()
    for path in sorted((ROOT / package).glob("*.py")):
        module = f"{package}.{path.stem}"
        graph.add_node(module)
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ImportFrom):
                base = f"{package}.{node.module}" if node.level == 1 and node.module else (node.module or "")
                names = [base] if node.level != 1 or node.module else [f"{package}.{a.name}" for a in node.names]
            elif isinstance(node, ast.Import):
                names = [alias.name for alias in node.names]
            else:
                continue
            for name in names:
                if name.split(".")[0] in ("skelcore", "app", "viser") and name != module:
                    graph.add_edge(module, name)
    return graph


def test_skelcore_never_imports_the_inspector_or_viser():
    reached = [(a, b) for a, b in _imports("skelcore").edges if b.split(".")[0] in ("app", "viser")]
    assert reached == []


def test_no_import_cycles():
    graph = nx.compose(_imports("skelcore"), _imports("app"))
    graph.remove_nodes_from([name for name in list(graph) if name in ("skelcore", "app")])
    assert list(nx.simple_cycles(graph)) == []
