"""What a command of `rig` can say: the strings of the source its callback reaches, by a static call graph (ast).

From a click command's callback, every name a function or class uses that resolves to a function, class or
module-level constant of the project (through its imports, those inside functions included, and re-exports) is
followed, and so are the names of what that reaches. A name bound locally (a parameter, an assignment) is not the
module's, and an attribute of a class (`Filters.parse`) reaches that method alone; an instance's method is not
resolved, so a class that is called or passed reaches all of its methods. The graph errs towards reaching more:
a message it reaches may still be one the command never shows, for a reason of data (a file it never passes).

The strings of a reached function are those it shows (its messages, the help texts of its click decorators),
not its docstring, except the callback's own, which is the command's help.
"""

from __future__ import annotations

import ast
import re
from dataclasses import dataclass
from pathlib import Path

import click

ROOT = Path(__file__).resolve().parents[2]
PACKAGES = ("rig", "procedures", "fixtures", "drivers")
OPTION = re.compile(r"(?<![\w-])--[a-zA-Z][\w-]*")
Key = tuple[str, str]            # (module, top-level name or "Class.method")


def command_tree(group: click.Group) -> dict[tuple[str, ...], click.Command]:
    """Every command under `group` by its words (("import", "csv"),), groups included."""
    out: dict[tuple[str, ...], click.Command] = {}

    def walk(cmd: click.Command, path: tuple[str, ...]) -> None:
        out[path] = cmd
        if isinstance(cmd, click.Group):
            ctx = click.Context(cmd)
            for name in cmd.list_commands(ctx):
                walk(cmd.get_command(ctx, name), (*path, name))

    walk(group, ())
    return out


def options_of(tree: dict[tuple[str, ...], click.Command]) -> dict[tuple[str, ...], set[str]]:
    """The long options a command line with these words can carry: the command's own and its groups'."""
    out: dict[tuple[str, ...], set[str]] = {}
    for path in sorted(tree, key=len):
        own = {o for p in tree[path].params for o in (*p.opts, *p.secondary_opts) if o.startswith("--")}
        out[path] = own | out.get(path[:-1], set())
    return out


def module_file(module: str, root: Path = ROOT) -> Path | None:
    for path in (root / (module.replace(".", "/") + ".py"), root / module.replace(".", "/") / "__init__.py"):
        if path.exists():
            return path
    return None


def _absolute(module: str, file: Path, node: ast.ImportFrom) -> str:
    if not node.level:
        return node.module or ""
    base = module.split(".") if file.name == "__init__.py" else module.split(".")[:-1]
    base = base[: len(base) - node.level + 1]
    return ".".join([*base, *([node.module] if node.module else [])])


def _aliases(module: str, file: Path, nodes, root: Path = ROOT) -> dict[str, tuple[str, ...]]:
    """name -> ("module", M) or ("object", M, attribute) for the project's imports among `nodes`."""
    out: dict[str, tuple[str, ...]] = {}
    for node in nodes:
        if isinstance(node, ast.Import):
            for a in node.names:
                if a.name.split(".")[0] in PACKAGES:
                    out[a.asname or a.name.split(".")[0]] = ("module", a.name if a.asname else a.name.split(".")[0])
        elif isinstance(node, ast.ImportFrom):
            source = _absolute(module, file, node)
            if source.split(".")[0] in PACKAGES:
                for a in node.names:
                    sub = f"{source}.{a.name}"
                    out[a.asname or a.name] = ("module", sub) if module_file(sub, root) else ("object", source, a.name)
    return out


class Module:
    def __init__(self, name: str, root: Path) -> None:
        self.name, self.file, self.root = name, module_file(name, root), root
        self.tree = ast.parse(self.file.read_text(), str(self.file))
        self.aliases = _aliases(name, self.file, [n for n in self.tree.body
                                                  if isinstance(n, (ast.Import, ast.ImportFrom))], root)
        self.defs: dict[str, ast.AST] = {}
        for node in self.tree.body:
            if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
                self.defs[node.name] = node
                if isinstance(node, ast.ClassDef):
                    for item in node.body:
                        if isinstance(item, (ast.FunctionDef, ast.AsyncFunctionDef)):
                            self.defs[f"{node.name}.{item.name}"] = item
            elif isinstance(node, (ast.Assign, ast.AnnAssign)):
                for target in node.targets if isinstance(node, ast.Assign) else [node.target]:
                    if isinstance(target, ast.Name):
                        self.defs[target.id] = node
        self.docstrings = {id(n.body[0].value) for n in ast.walk(self.tree)
                           if isinstance(n, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef))
                           and n.body and isinstance(n.body[0], ast.Expr)
                           and isinstance(n.body[0].value, ast.Constant) and isinstance(n.body[0].value.value, str)}


@dataclass
class Said:
    """A string a command can show: where it is, and the calls that lead there."""

    module: str
    line: int
    text: str
    chain: tuple[Key, ...]


class Source:
    """The project's modules (under `root`), parsed when first asked for."""

    def __init__(self, root: Path = ROOT) -> None:
        self.root = root
        self.modules: dict[str, Module | None] = {}
        self._uses: dict[Key, set[Key]] = {}
        self._strings: dict[tuple[Key, bool], list[tuple[int, str]]] = {}

    def module(self, name: str) -> Module | None:
        if name not in self.modules:
            self.modules[name] = Module(name, self.root) if module_file(name, self.root) else None
        return self.modules[name]

    def resolve(self, module: Module, name: str, depth: int = 0) -> Key | None:
        """The definition `name` stands for in `module`, through re-exports."""
        if name in module.defs:
            return module.name, name
        alias = module.aliases.get(name)
        if alias and alias[0] == "object" and depth < 20:
            target = self.module(alias[1])
            return self.resolve(target, alias[2], depth + 1) if target else None
        return None

    def _through(self, alias: tuple[str, ...], attribute: str | None) -> Key | None:
        if alias[0] == "object":
            target = self.module(alias[1])
            key = self.resolve(target, alias[2]) if target else None
            return self._member(key, attribute) if key and attribute else key
        target = self.module(alias[1])
        return self.resolve(target, attribute) if target and attribute else None

    def _member(self, key: Key, attribute: str) -> Key:
        module = self.module(key[0])
        method = f"{key[1]}.{attribute}"
        return (key[0], method) if isinstance(module.defs.get(key[1]), ast.ClassDef) and method in module.defs else key

    def uses(self, key: Key) -> set[Key]:
        """The definitions one definition names (a type annotation is not a use)."""
        if key not in self._uses:
            self._uses[key] = self._named(key)
        return self._uses[key]

    def _named(self, key: Key) -> set[Key]:
        module = self.module(key[0])
        node = module.defs[key[1]]
        nodes = list(ast.walk(node))
        local = _aliases(module.name, module.file, [n for n in nodes if isinstance(n, (ast.Import, ast.ImportFrom))],
                         self.root)
        bound = set()
        if not isinstance(node, (ast.Assign, ast.AnnAssign)):
            for n in nodes:
                if isinstance(n, ast.arg):
                    bound.add(n.arg)
                elif isinstance(n, ast.Name) and isinstance(n.ctx, ast.Store):
                    bound.add(n.id)
                elif isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)) and n is not node:
                    bound.add(n.name)
        if "." in key[1]:                                    # a method: the names its class's methods go by
            bound -= {"self", "cls"}
        out: set[Key] = set()
        seen_names = {id(a) for n in nodes for annotation in _annotations(n) for a in ast.walk(annotation)}
        for n in nodes:
            if id(n) in seen_names:
                continue
            if isinstance(n, ast.Attribute) and isinstance(n.value, ast.Name):
                name = n.value.id
                seen_names.add(id(n.value))
                if name in ("self", "cls") and "." in key[1]:
                    owner = key[1].split(".")[0]
                    if f"{owner}.{n.attr}" in module.defs:
                        out.add((key[0], f"{owner}.{n.attr}"))
                    continue
                if name in local:
                    found = self._through(local[name], n.attr)
                elif name in bound:
                    found = None
                elif name in module.aliases:
                    found = self._through(module.aliases[name], n.attr)
                else:
                    found = self.resolve(module, name)
                    found = self._member(found, n.attr) if found else None
                if found:
                    out.add(found)
        for n in nodes:
            if isinstance(n, ast.Name) and id(n) not in seen_names and isinstance(n.ctx, ast.Load):
                if n.id in local:
                    found = self._through(local[n.id], None)
                elif n.id in bound:
                    found = None
                else:
                    found = self.resolve(module, n.id)
                if found:
                    out.add(found)
        if isinstance(node, ast.ClassDef):                   # a class used whole: every method of it
            out |= {(key[0], name) for name in module.defs if name.startswith(f"{key[1]}.")}
        out.discard(key)
        return out

    def reach(self, start: Key) -> dict[Key, tuple[Key, ...]]:
        """Every definition reachable from `start`, with the chain of definitions that leads to it."""
        chains = {start: (start,)}
        todo = [start]
        while todo:
            key = todo.pop(0)
            for used in sorted(self.uses(key)):
                if used not in chains:
                    chains[used] = (*chains[key], used)
                    todo.append(used)
        return chains

    def strings(self, key: Key, *, with_docstring: bool = False) -> list[tuple[int, str]]:
        """(line, text) of every string a definition holds; an f-string whole, its fields as {}."""
        if (key, with_docstring) not in self._strings:
            self._strings[key, with_docstring] = self._held(key, with_docstring)
        return self._strings[key, with_docstring]

    def _held(self, key: Key, with_docstring: bool) -> list[tuple[int, str]]:
        module = self.module(key[0])
        nodes = list(ast.walk(module.defs[key[1]]))
        parts = {id(v) for n in nodes if isinstance(n, ast.JoinedStr) for v in n.values}
        out = []
        for n in nodes:
            if isinstance(n, ast.JoinedStr):
                out.append((n.lineno, "".join(v.value if isinstance(v, ast.Constant) else "{}" for v in n.values)))
            elif (isinstance(n, ast.Constant) and isinstance(n.value, str) and id(n) not in parts
                  and (with_docstring or id(n) not in module.docstrings)):
                out.append((n.lineno, n.value))
        return out

    def said_by(self, callback) -> list[Said]:
        """The strings the command whose callback this is can show."""
        while hasattr(callback, "__wrapped__"):
            callback = callback.__wrapped__
        start = (callback.__module__, callback.__qualname__.split(".")[0])
        out = []
        for key, chain in self.reach(start).items():
            for line, text in self.strings(key, with_docstring=key == start):
                out.append(Said(key[0], line, text, chain))
        return out


def _annotations(node: ast.AST) -> list[ast.AST]:
    if isinstance(node, ast.arg):
        return [node.annotation] if node.annotation else []
    if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef)):
        return [node.returns] if node.returns else []
    if isinstance(node, ast.AnnAssign):
        return [node.annotation]
    return []


def named_command(before: str, paths: set[tuple[str, ...]]) -> tuple[str, ...] | None:
    """The command a text names just before an option ("rig import ... --initial-rest-s S", "`plan --budget-s`"):
    the option is then that command's, not the one showing the text."""
    before = before.replace("...", " ")
    words = r"([a-z][\w-]*)(?: ([a-z][\w-]*))?"
    found = re.search(rf"\brig {words}[^;,()`.]*$", before) or re.search(rf"`{words} [^`]*$", before)
    if not found:
        return None
    first, second = found.group(1), found.group(2)
    if second and (first, second) in paths:
        return first, second
    return (first,) if (first,) in paths else None


@dataclass
class Finding:
    """An option a command can name in what it says, which the command line it names it for does not take."""

    command: tuple[str, ...]
    option: str
    said: Said

    @property
    def key(self) -> tuple[str, str, str]:
        return " ".join(self.command), self.said.module, self.option

    def __str__(self) -> str:
        chain = " > ".join(f"{m}:{name}" for m, name in self.said.chain)
        return (f"`rig {' '.join(self.command)}` can say {self.option} ({self.said.module}, line {self.said.line}: "
                f"{self.said.text[:90]!r}), through {chain}")


def options_not_taken(tree: dict[tuple[str, ...], click.Command], source: Source) -> list[Finding]:
    """Every option a command's reachable strings name that its command line does not take: the command's own, or
    the one the string names ("rig import ... --initial-rest-s"; of a group, any of its commands')."""
    options = options_of(tree)
    out = []
    for path, command in tree.items():
        if isinstance(command, click.Group) or command.callback is None:
            continue
        for said in source.said_by(command.callback):
            for hit in OPTION.finditer(said.text):
                target = named_command(said.text[:hit.start()], set(tree)) or path
                within = [p for p in tree if p[:len(target)] == target] if isinstance(tree[target], click.Group) \
                    else [target]
                if not any(hit.group() in options[p] for p in within):
                    out.append(Finding(path, hit.group(), said))
    return out
