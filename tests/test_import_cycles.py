"""No import cycle between the package's modules (issue "One engine a newcomer can extend": the last one,
io.model_files <-> io.mjcf, is gone). Lazy imports inside functions count too: grimp reads every import statement."""

from __future__ import annotations

import grimp


def test_no_module_imports_itself_through_others() -> None:
    graph = grimp.build_graph("freefloat", include_external_packages=False, exclude_type_checking_imports=True)  # annotations only
    cycles = []
    for module in sorted(graph.modules):
        for imported in graph.find_modules_directly_imported_by(module):
            if imported.startswith(module + ".") or module.startswith(imported + "."):
                continue  # a package and its own modules (the namespaces re-export)
            back = graph.find_shortest_chain(importer=imported, imported=module)
            if back is not None and not any(m.startswith(module + ".") for m in back):
                cycles.append(" -> ".join((module, *back)))
    assert cycles == [], "\n".join(cycles)
