"""Issue 57, the front door at the command line: no message names an option that does not exist,
and every table fits an 80-column terminal without cutting a word.

References: the options are the click commands' own (``haptex.cli.cli``); a table's words are
those it prints in a terminal wide enough for every cell on one line (400 columns)."""

import ast
import re
from collections import Counter
from pathlib import Path

import click
import pytest

import haptex
from haptex.cli import cli

SRC = Path(haptex.__file__).parent
ROOT = Path(__file__).resolve().parent.parent  # (the clone: its README and docs)


def _options() -> set:
    names = {"--help", "--version", "-h"}

    def walk(cmd):
        for param in cmd.params:
            if isinstance(param, click.Option):
                names.update(param.opts)
                names.update(param.secondary_opts)
        for sub in getattr(cmd, "commands", {}).values():
            walk(sub)

    walk(cli)
    return names


def test_every_option_a_message_or_help_names_exists():
    # every '--option' written in the package's strings (refusals, hints, help texts, f-strings'
    # literal parts) is an option of a haptex command: a remedy the user can type. Before issue 57
    # a surfaces.py hint named --pixel-size, which no command has.
    options, named = _options(), {}
    for path in SRC.rglob("*.py"):
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.Constant) and isinstance(node.value, str):
                # (after a comma: a compiler's pass-through to the linker, -Wl,--gc-sections)
                for opt in re.findall(r"(?<![\w,-])--[a-z][a-z0-9-]*", node.value):
                    named.setdefault(opt, set()).add(path.name)
    assert len(named) > 40  # the scan sees the CLI's own option names too
    assert {opt: files for opt, files in named.items() if opt not in options} == {}


def _words(text: str) -> Counter:
    return Counter(w for w in text.split() if not set(w) <= set("─━═│┃┏┓┗┛┡┩┳┻╇╈╋┼"))


@pytest.mark.parametrize("args", [
    ("devices",), ("devices", "--wide"), ("devices", "show", "falcon"), ("table",),
    ("design", "--texture", "sine:0.2mm,2mm", "--algorithms", "W,A,C", "--quiet"),
    ("simulate", "thrust", "--algorithm", "A", "--stiffness", "2kN/m", "--duration", "0.1s"),
], ids=lambda a: " ".join(a[:3]))
def test_tables_fit_80_columns_and_keep_every_word_whole(args, monkeypatch):
    import haptex.tables

    from .test_cli import run_main

    # Table II computed once for both widths (the layout is the test; 1.4 s a computation)
    table_ii, memo = haptex.tables.table_ii, {}

    def once(*a, **k):
        key = repr((a, k))
        if key not in memo:
            memo[key] = table_ii(*a, **k)
        return memo[key]

    monkeypatch.setattr(haptex.tables, "table_ii", once)

    def run(columns):  # (in this process: rich reads the environment when a command makes its console)
        monkeypatch.setenv("COLUMNS", str(columns))
        monkeypatch.setenv("TERM", "dumb")
        r = run_main(*args)
        assert r.returncode == 0, r.stderr
        return r.stdout

    narrow, wide = run(80), run(400)
    assert max(len(line) for line in narrow.splitlines()) <= 80
    assert "…" not in narrow
    assert _words(narrow) == _words(wide)  # nothing cut, folded or dropped: the same words as one line each


def _module_imports() -> dict:
    """Every module of the installed package -> the package's modules it imports anywhere in
    its text (at the top or inside a function), read from the source by :mod:`ast`."""
    files = {}
    for path in SRC.rglob("*.py"):
        parts = path.relative_to(SRC.parent).with_suffix("").parts
        is_package = parts[-1] == "__init__"
        files[".".join(parts[:-1] if is_package else parts)] = (path, is_package)

    def resolve(name):  # a module of ours, or the package whose attribute it is
        while name and name not in files:
            name = name.rpartition(".")[0]
        return name or None

    graph = {}
    for mod, (path, is_package) in files.items():
        package = mod if is_package else mod.rpartition(".")[0]
        edges = set()
        for node in ast.walk(ast.parse(path.read_text(encoding="utf-8"))):
            if isinstance(node, ast.ImportFrom):
                base = package
                for _ in range(max(node.level - 1, 0)):
                    base = base.rpartition(".")[0]
                base = (f"{base}.{node.module}" if node.module else base) if node.level else node.module or ""
                if not base.startswith("haptex"):
                    continue
                for alias in node.names:
                    target = resolve(f"{base}.{alias.name}")
                    if target and target.startswith("haptex"):
                        edges.add(target)
            elif isinstance(node, ast.Import):
                edges.update(t for a in node.names if (t := resolve(a.name)) and t.startswith("haptex"))
        edges.discard(mod)
        graph[mod] = edges
    return graph


def test_the_modules_import_no_circle():
    # Issue 57: "the import circles broken, so each module's layer is plain". A package's
    # __init__ gathers its modules (haptex.__all__, the CLI's commands), so arrows into a
    # package's own __init__ from inside it are that gathering, not a layer: they are left out.
    # Reference: Tarjan's strongly connected components (scipy.sparse.csgraph); a circle is a
    # component of more than one module.
    from scipy.sparse import csr_matrix
    from scipy.sparse.csgraph import connected_components

    graph = _module_imports()
    names = sorted(graph)
    index = {m: i for i, m in enumerate(names)}
    rows, cols = [], []
    for mod, targets in graph.items():
        for t in targets:
            if mod.startswith(t + "."):  # a module of a package importing its own __init__
                continue
            rows.append(index[mod])
            cols.append(index[t])
    matrix = csr_matrix(([1] * len(rows), (rows, cols)), shape=(len(names),) * 2)
    count, labels = connected_components(matrix, directed=True, connection="strong")
    circles = [sorted(m for m in names if labels[index[m]] == k) for k in range(count)]
    circles = [c for c in circles if len(c) > 1]
    assert len(graph) > 40 and sum(map(len, graph.values())) > 150  # the reader sees the package
    assert circles == [], f"import circles: {circles}"


# -- the commands the documentation shows --------------------------------------------------
_WRITES = ("-o", "--out", "--record", "--save", "--plot")
_FILE = re.compile(r"\.(csv|tsv|txt|mat|dat|mi|nc|x3p|opdx|di|toml|yaml|json|npz|zarr|h5|hdf5|obj|stl|png|xml)$", re.I)


def _documented_commands():
    """Every ``haptex`` command line in README.md's and the docs' shell blocks, with its page
    (continuation lines joined, comments and printed output dropped): [(page, argv), ...]."""
    import shlex

    root = ROOT
    out = []
    for page in [root / "README.md", *sorted((root / "docs").rglob("*.md"))]:
        for block in re.findall(r"```(?:bash|console|shell|sh)\n(.*?)```", page.read_text(), re.S):
            for line in block.replace("\\\n", " ").splitlines():
                line = line.strip().removeprefix("$ ")
                for part in line.split("&&"):  # (README's "pip install . && haptex reproduce")
                    part = part.strip()
                    if part.startswith("haptex ") or part == "haptex":
                        out.append((page.relative_to(root).as_posix(), shlex.split(part, comments=True)[1:]))
    return out


def _parse(argv):
    """Parse argv as ``haptex`` would, down to its subcommand, running nothing (click raises
    UsageError on an unknown option or a bad value); --help and --version end it with status 0."""
    cmd, ctx, args = cli, None, list(argv)
    try:
        while True:
            ctx = cmd.make_context(cmd.name or "haptex", args, parent=ctx)
            if not isinstance(cmd, click.Group):
                return
            rest = [*getattr(ctx, "_protected_args", []), *ctx.args]
            if not rest:
                return
            _, cmd, args = cmd.resolve_command(ctx, rest)
    except click.exceptions.Exit as done:
        assert done.exit_code == 0, argv


def test_every_command_the_docs_show_parses_and_names_files_that_exist():
    # A reader copies a guide's command into a shell at the clone's root (README: "Set up on a
    # fresh machine"). Reference: the click commands themselves (each line parsed by them, as the
    # shell would pass it), and the files in the clone and beside it: a file the project ships
    # (examples/, ../shared/data/) must be named by its path from the clone's root. Before:
    # running-on-a-device's "--texture grooves-4mm-profile.mat" and firmware-export's
    # "--texture x3p-2.x3p" named shipped files without their folders ("no such file").
    root = ROOT
    shipped = {f.name for where in (root / "examples", root.parent / "shared" / "data") if where.exists()
               for f in where.rglob("*") if f.is_file()}
    commands = _documented_commands()
    assert len(commands) > 50  # (the guides show that many)
    written, wrong = {}, []
    for page, argv in commands:
        _parse(argv)
        for before, arg in zip(["haptex", *argv], argv):
            if before in _WRITES:
                written.setdefault(page, set()).add(arg)
            elif _FILE.search(arg) and arg not in written.get(page, ()) and not (root / arg).exists() \
                    and Path(arg).name in shipped:
                wrong.append(f"{page}: haptex {' '.join(argv)} (no {arg} from the clone's root)")
    assert wrong == []


def test_every_name_the_docs_python_uses_exists_and_takes_its_keywords():
    # The guides' Python snippets use names from their prose (alg, tex), so they are not run as
    # pasted; what a reader types from them is haptex's names and keywords. Reference: the
    # modules themselves (importlib, getattr) and each callable's signature (inspect): every
    # `from haptex... import name`, every attribute chain on haptex (hx), haptex.datadriven (dd)
    # and haptex.core (core), and the keywords of every call of such a name.
    import ast
    import importlib
    import importlib.util
    import inspect

    aliases = {"hx": "haptex", "dd": "haptex.datadriven", "core": "haptex.core"}
    wrong, checked = [], 0
    for page in [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md"))]:
        for block in re.findall(r"```(?:python|py)\n(.*?)```", page.read_text(), re.S):
            tree = ast.parse(block)
            names = dict(aliases)
            for node in ast.walk(tree):
                if isinstance(node, ast.ImportFrom) and (node.module or "").startswith("haptex"):
                    module = importlib.import_module(node.module)
                    for a in node.names:
                        if hasattr(module, "__path__") and importlib.util.find_spec(f"{node.module}.{a.name}"):
                            importlib.import_module(f"{node.module}.{a.name}")  # (a package's submodule)
                        if not hasattr(module, a.name):
                            wrong.append(f"{page.name}: from {node.module} import {a.name}")
                        elif inspect.ismodule(getattr(module, a.name)):
                            names[a.asname or a.name] = f"{node.module}.{a.name}"
                        else:
                            names[a.asname or a.name] = (node.module, a.name)
                        checked += 1
                elif isinstance(node, ast.Import):
                    for a in node.names:
                        if a.name.startswith("haptex"):
                            names[a.asname or a.name] = a.name

            def resolve(expr):
                """The object an attribute chain on a haptex name stands for, or None (not ours)."""
                if isinstance(expr, ast.Name) and expr.id in names:
                    where = names[expr.id]
                    if isinstance(where, tuple):
                        return getattr(importlib.import_module(where[0]), where[1])
                    return importlib.import_module(where)
                if isinstance(expr, ast.Attribute):
                    base = resolve(expr.value)
                    if base is None:
                        return None
                    if not hasattr(base, expr.attr):
                        wrong.append(f"{page.name}: {ast.unparse(expr)}")
                        return None
                    return getattr(base, expr.attr)
                return None

            for node in ast.walk(tree):
                if isinstance(node, ast.Attribute) and isinstance(node.ctx, ast.Load):
                    resolve(node)
                    checked += 1
                elif isinstance(node, ast.Call) and node.keywords:
                    target = resolve(node.func)
                    if target is None or not callable(target):
                        continue
                    try:
                        params = inspect.signature(target).parameters
                    except (TypeError, ValueError):  # (a C function without a signature)
                        continue
                    if any(p.kind is p.VAR_KEYWORD for p in params.values()):
                        continue
                    for kw in node.keywords:
                        if kw.arg is not None and kw.arg not in params:
                            wrong.append(f"{page.name}: {ast.unparse(node.func)}(..., {kw.arg}=...)")
                    checked += 1
    assert checked > 60  # (the snippets hold that many)
    assert sorted(set(wrong)) == []
