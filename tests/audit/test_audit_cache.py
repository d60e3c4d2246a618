"""The audit's results reused by input hash (tests/audit/audit_cache.py): the key changes with the
record's bytes and covers every source the audit can reach."""

from __future__ import annotations

import ast
import shutil

import audit_cache

from cosim.project.paths import REPO_ROOT


def _module_file(name: str):
    base = REPO_ROOT.joinpath(*name.split("."))
    for f in (base.with_suffix(".py"), base / "__init__.py"):
        if f.is_file():
            return f
    return None


def _imports(path, package: str) -> set[str]:
    """Every cosim module `path` imports, at its top or inside a function."""
    out = set()
    for node in ast.walk(ast.parse(path.read_text())):
        if isinstance(node, ast.Import):
            out |= {a.name for a in node.names if a.name.startswith("cosim")}
        elif isinstance(node, ast.ImportFrom):
            if node.level:
                base = package.rsplit(".", node.level - 1)[0] if node.level > 1 else package
                mod = f"{base}.{node.module}" if node.module else base
            else:
                mod = node.module or ""
            if mod.startswith("cosim"):
                out.add(mod)
                out |= {f"{mod}.{a.name}" for a in node.names}  # a submodule imported by name
    return out


def test_every_source_the_audit_reaches_is_in_the_key():
    """Following every import from cosim.audit (also those inside functions) reaches only files
    under audit_cache.SOURCES: a change to any of them changes the key."""
    roots = [REPO_ROOT / s for s in audit_cache.SOURCES]
    seen, todo = set(), ["cosim.audit"]
    todo += [f"cosim.audit.{p.stem}" for p in (REPO_ROOT / "cosim" / "audit").glob("*.py")]
    outside = []
    while todo:
        name = todo.pop()
        f = _module_file(name)
        if f is None or f in seen:
            continue
        seen.add(f)
        if not any(f == r or r in f.parents for r in roots):
            outside.append(str(f.relative_to(REPO_ROOT)))
        package = name if f.name == "__init__.py" else name.rsplit(".", 1)[0]
        parts = name.split(".")
        todo += [".".join(parts[:i]) for i in range(1, len(parts))]  # the packages' __init__s
        todo += sorted(_imports(f, package))
    assert len(seen) > 20, len(seen)  # the walk found the audit's modules
    assert outside == [], outside


def test_the_key_follows_the_records_bytes_not_its_name(tmp_path):
    a = tmp_path / "a.csv"
    a.write_text("t_s,T_in_N,T_out_N\n0,1,1\n")
    b = tmp_path / "b.csv"
    shutil.copy(a, b)
    assert audit_cache.record_digest(a) == audit_cache.record_digest(b)
    b.write_text("t_s,T_in_N,T_out_N\n0,1,1.001\n")
    assert audit_cache.record_digest(a) != audit_cache.record_digest(b)
    before = audit_cache.record_digest(a)
    (tmp_path / "a.meta.json").write_text('{"sheath_length_m": 1.0}')  # the sidecar counts too
    assert audit_cache.record_digest(a) != before
