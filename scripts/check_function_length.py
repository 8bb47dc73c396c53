#!/usr/bin/env python3
"""Checks that no function in prt's non-test C++ sources is longer than a
limit (issue 46).

What is a function: every body `{ ... }` of a free function, a member function
(defined in or out of its class), a constructor, an operator, a macro-declared
body such as PYBIND11_MODULE(...) { ... }, and a lambda at namespace or class
scope (`auto f = [](...) { ... };`, counted as a function of its own). A lambda
or a local class inside a function is part of the enclosing function.

Length: the lines from the line holding the body's opening brace to the line
holding its closing brace, both inclusive (a one-line `{ return x; }` is 1
line); the signature above the brace does not count. The line printed is the
line of the function's name.

The scanner blanks comments (// and /* */), string literals (also raw strings
R"x(...)x" with any prefix), character literals and preprocessor lines before
it matches braces; digit separators (1'000) are no character literals.

Searched: core/ scene/ precompute/ analysis/ runtime/ tools/ python/src/
include/ bench/ (files *.cpp *.cc *.cxx *.h *.hpp *.inl); never tests/ or build/.

Usage: check_function_length.py [--limit N] SOURCE_DIR
            one line `path:line: name: N lines` per function over N lines
            (default 150); exit 1 if any (or if a file's braces do not
            balance), 0 otherwise
       check_function_length.py --list [--limit N] SOURCE_DIR
            the 30 longest functions whatever the limit; exit 0
       check_function_length.py --self-test [SOURCE_DIR]
            plants cases in a temporary tree and checks the findings; exit 1
            on a failure
"""
import argparse
import pathlib
import re
import sys
import tempfile

FOLDERS = ["core", "scene", "precompute", "analysis", "runtime", "tools", "python/src", "include", "bench"]
EXTENSIONS = {".cpp", ".cc", ".cxx", ".h", ".hpp", ".inl"}
EXCLUDED_PARTS = {"tests", "build"}
DEFAULT_LIMIT = 150
LIST_COUNT = 30

RAW_STRING = re.compile(r'(?:u8|u|U|L)?R"([^()\\\s]{0,16})\(')


def blank(text: str) -> str:
    """text with comments, string and character literals and preprocessor
    lines replaced by spaces (newlines kept, so line numbers hold). A string
    keeps its quotes (`extern "C"` stays recognisable)."""
    out = list(text)
    n = len(text)
    i = 0
    line_start = True  # only whitespace since the last newline

    def wipe(a, b):
        for k in range(a, b):
            if out[k] != "\n":
                out[k] = " "

    while i < n:
        c = text[i]
        if c == "\n":
            line_start = True
            i += 1
            continue
        if c in " \t\r\f\v":
            i += 1
            continue
        if line_start and c == "#":
            # A preprocessor line, with its continuations and comments.
            j = i
            while j < n and text[j] != "\n":
                if text.startswith("/*", j):
                    end = text.find("*/", j + 2)
                    j = n if end < 0 else end + 2
                    continue
                if text[j] == "\\" and j + 1 < n and text[j + 1] == "\n":
                    j += 2
                    continue
                j += 1
            wipe(i, j)
            i = j
            continue
        line_start = False
        if text.startswith("//", i):
            j = i
            while j < n and text[j] != "\n":
                j += 2 if text[j] == "\\" and j + 1 < n and text[j + 1] == "\n" else 1
            wipe(i, j)
            i = j
            continue
        if text.startswith("/*", i):
            end = text.find("*/", i + 2)
            j = n if end < 0 else end + 2
            wipe(i, j)
            i = j
            continue
        if c == "R" or c in "uUL":
            m = RAW_STRING.match(text, i)
            if m and not (i > 0 and (text[i - 1].isalnum() or text[i - 1] == "_")):
                close = ")" + m.group(1) + '"'
                end = text.find(close, m.end())
                j = n if end < 0 else end + len(close)
                wipe(i, j)
                i = j
                continue
        if c == '"':
            j = i + 1
            while j < n and text[j] != '"' and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            wipe(i + 1, min(j, n))  # keep the quotes
            i = j + 1
            continue
        if c == "'":
            # A digit separator when the token before it is a number.
            k = i
            while k > 0 and (text[k - 1].isalnum() or text[k - 1] in "_.'"):
                k -= 1
            if k < i and text[k].isdigit():
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != "'" and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            wipe(i, min(j + 1, n))
            i = j + 1
            continue
        if c.isalnum() or c == "_":
            j = i
            while j < n and (text[j].isalnum() or text[j] == "_"):
                j += 1
            i = j
            continue
        i += 1
    return "".join(out)


def strip_angles(head: str) -> str:
    """head with `template <...>` parameter lists and [[attributes]] blanked
    (positions kept)."""
    def spaces(t):
        return re.sub(r"[^\n]", " ", t)

    head = re.sub(r"\[\[.*?\]\]", lambda m: spaces(m.group(0)), head, flags=re.S)
    while True:
        m = re.search(r"\btemplate\s*<", head)
        if not m:
            return head
        depth, j = 0, m.end() - 1
        while j < len(head):
            if head[j] == "<":
                depth += 1
            elif head[j] == ">":
                depth -= 1
                if depth == 0:
                    break
            j += 1
        head = head[:m.start()] + spaces(head[m.start():j + 1]) + head[j + 1:]


def top_level(head: str) -> str:
    """head with the contents of (), [] and {} replaced by spaces."""
    out, depth = [], 0
    for ch in head:
        if ch in "([{":
            out.append(ch if depth == 0 else " ")
            depth += 1
        elif ch in ")]}":
            depth = max(depth - 1, 0)
            out.append(ch if depth == 0 else " ")
        else:
            out.append(ch if depth == 0 else " ")
    return "".join(out)


LAMBDA_TAIL = re.compile(r"\[[^\[\]]*\]\s*(?:\((?:[^()]|\([^()]*\))*\))?\s*"
                         r"(?:(?:mutable|constexpr|consteval|static|noexcept)\s*)*(?:->\s*[\w:<>,\s*&]+)?\s*$")
OPERATOR = re.compile(r"((?:[A-Za-z_~]\w*\s*(?:<[^()]*>)?\s*::\s*)*operator\s*"
                      r"(?:\(\s*\)|\[\s*\]|[^\s\w(]+|\s+[A-Za-z_][\w:<>*&\s]*?))\s*\(")
NOT_NAMES = {"decltype", "alignas", "__attribute__", "__declspec", "noexcept", "requires", "sizeof",
             "static_assert", "if", "for", "while", "switch", "return", "throw"}
NAME_BEFORE_PAREN = re.compile(r"((?:[A-Za-z_~][\w]*\s*(?:<[^()]*>)?\s*::\s*)*"
                               r"(?:operator\s*(?:\(\s*\)|[^\s(]+|\s\w[\w\s:<>*&]*)|~?[A-Za-z_]\w*))\s*(?:<[^()]*>)?\s*$")


def classify(head: str):
    """(kind, name, offset of the name in head) for a `{` at namespace or
    class scope whose preceding text is head: kind is 'namespace', 'class',
    'function', 'lambda', 'init' (a braced initialiser, whose closing brace
    keeps the statement going) or 'block'."""
    h = strip_angles(head)
    if re.match(r"^\s*(inline\s+)?namespace\b", h) or re.match(r'^\s*extern\s*"[^"]*"\s*$', h):
        return "namespace", "", 0
    top = top_level(h)
    # `[captures](params) ... {`: a lambda at namespace or class scope, named
    # after the variable it initialises when there is one.
    m = LAMBDA_TAIL.search(h)
    if m and not re.search(r"[\w)\]]\s*$", h[:m.start()]):
        if re.search(r"\)[^()]*?(?<!:):(?!:)", top_level(h[:m.start()])):
            return "init", "", 0  # in a member initialiser: part of the constructor
        var = re.search(r"([A-Za-z_]\w*)\s*=\s*$", h[:m.start()])
        return "lambda", var.group(1) if var else "", var.start(1) if var else m.start()
    if h.count("(") > h.count(")"):  # an argument: `f({1, 2})`
        return "init", "", 0
    if re.match(r"^\s*(typedef\s+)?(class|struct|union|enum)\b", h):
        m = re.match(r"^\s*(?:typedef\s+)?(?:class|struct|union|enum)(?:\s+(?:class|struct))?\s+"
                     r"(?:(?:alignas|__attribute__|__declspec)\s*\([^)]*\)\s*)*([A-Za-z_]\w*)?", h)
        return "class", (m.group(1) or "") if m else "", 0
    without_ops = re.sub(r"\boperator\s*[^\s(]*=", "operator", top)
    if "=" in without_ops.replace("==", "").replace("!=", "").replace("<=", "").replace(">=", ""):
        return "init", "", 0
    if "(" not in top:
        return ("init" if re.search(r"[\w>]\s*$", top) else "block"), "", 0
    # Member initialisers: `X::X(a) : m_{a}, n_(b) {` — a brace right after a
    # name or template argument list opens an initialiser, not the body.
    colon = re.search(r"\)[^()]*?(?<!:):(?!:)", top)
    if colon and re.search(r"[\w>]\s*$", top):
        return "init", "", 0
    m = OPERATOR.search(top)
    if m:
        return "function", " ".join(m.group(1).split()).replace(" ::", "::").replace(":: ", "::"), m.start(1)
    for m in re.finditer(r"\(", top):
        before = top[:m.start()]
        nm = NAME_BEFORE_PAREN.search(before)
        if not nm:
            continue
        name = re.sub(r"\s+", "", nm.group(1)) if "operator" not in nm.group(1) else " ".join(nm.group(1).split())
        last = re.split(r"::", name)[-1]
        if last in NOT_NAMES:
            continue
        return "function", name, nm.start(1)
    return "block", "", 0


def matching_brace(code: str, i: int):
    """(index after the `}` matching the `{` at i, newlines in between), or
    (len(code), ...) when it has none."""
    depth, j, n = 1, i + 1, len(code)
    while j < n and depth:
        if code[j] == "{":
            depth += 1
        elif code[j] == "}":
            depth -= 1
        j += 1
    return j, code.count("\n", i, j), depth == 0


def functions(text: str):
    """[(name, name_line, first_line, last_line)] of the functions in text,
    and whether its braces balance. A function's or lambda's body and a
    braced initialiser are taken whole; the scanner descends only into
    namespaces, classes and other blocks at namespace scope."""
    code = blank(text)
    found = []
    stack = []  # the enclosing namespaces, classes and blocks: (kind, name)
    head_start = 0  # where the declaration before the next `{` begins
    line = 1
    i, n = 0, len(code)
    balanced = True
    while i < n:
        c = code[i]
        if c == "\n":
            line += 1
        elif c == ";":
            head_start = i + 1
        elif c == "}":
            if stack:
                stack.pop()
            else:
                balanced = False
            head_start = i + 1
        elif c == "{":
            head = code[head_start:i]
            kind, name, pos = classify(head)
            if kind in ("function", "lambda", "init"):
                j, lines, closed = matching_brace(code, i)
                balanced = balanced and closed
                if kind != "init":
                    classes = [nm for k, nm in stack if k == "class" and nm]
                    if kind == "lambda":
                        name = f"{name} (lambda)" if name else "(lambda)"
                    if classes and "::" not in name:
                        name = "::".join(classes + [name])
                    found.append((name, line - head[pos:].count("\n"), line, line + lines))
                if kind == "function":
                    head_start = j  # a lambda or an initialiser goes on with its statement
                line += lines
                i = j
                continue
            stack.append((kind, name))
            head_start = i + 1
        i += 1
    return found, balanced and not stack


def sources(root: pathlib.Path):
    for folder in FOLDERS:
        base = root / folder
        if not base.is_dir():
            continue
        for p in sorted(base.rglob("*")):
            rel = p.relative_to(root)
            if p.suffix in EXTENSIONS and p.is_file() and not EXCLUDED_PARTS & set(rel.parts):
                yield p, rel.as_posix()


def scan(root: pathlib.Path):
    """([(length, path, line, name)], [unbalanced paths])"""
    rows, broken = [], []
    for p, rel in sources(root):
        found, ok = functions(p.read_text(encoding="utf-8", errors="replace"))
        if not ok:
            broken.append(rel)
        for name, name_line, first, last in found:
            rows.append((last - first + 1, rel, name_line, name))
    return rows, broken


def check(root: pathlib.Path, limit: int):
    """The report lines: offenders and files the scanner could not balance."""
    rows, broken = scan(root)
    lines = [f"{path}:{line}: {name}: {length} lines"
             for length, path, line, name in sorted(rows, key=lambda r: (r[1], r[2])) if length > limit]
    lines += [f"{path}: braces do not balance (the scanner cannot measure this file)" for path in broken]
    return lines


def self_test() -> int:
    def body(k):
        return "".join(f"    x += {j};\n" for j in range(k))

    files = {
        # 1 + 158 + 1 = 160 lines from brace to brace; the name on line 3.
        "core/long.cpp": "#include <x>\n// {\nint long_one(int x)\n{\n" + body(158) + "}\n"
                         "int short_one() { return 1; }\n",
        # Braces in a raw string, a comment, char literals and a digit separator.
        "scene/tricky.cpp": 'namespace a {\nconst char* s() {\n  return R"x(}}}{ )" })x";\n}\n'
                            "/* { { { */\nchar c() { return '{'; }\nint d() { return 1'000 + '}'; }\n"
                            "int e() {\n" + body(150) + "  return '\\''; // }\n}\n}  // namespace a\n",
        # A lambda inside a function counts with it: 2 + 70 + 80 + 1 lines.
        "precompute/lam.cpp": "void outer() {\n  auto f = [&](int i) {\n" + body(70) + "  };\n" + body(80) + "}\n"
                              # A lambda at namespace scope is a function of its own.
                              "const auto ns_lambda = [](int x) {\n" + body(155) + "};\n",
        # Member functions: in the class (with its name), a constructor with
        # braced member initialisers, an operator=.
        "include/prt/cls.h": "struct Box {\n  int m_{0};\n  Box(int a) : m_{a}, n_(a) {\n" + body(151) + "  }\n"
                             "  Box& operator=(const Box&) {\n" + body(160) + "    return *this;\n  }\n"
                             "  int n_;\n};\n"
                             "static const int table[] = {1, 2, 3};\n",
        # extern "C" blocks and functions, operator(), a lambda in a member
        # initialiser (part of the constructor), braces in a call's arguments.
        "runtime/more.cpp": 'extern "C" {\nint c_fn() {\n' + body(151) + '}\n}\n'
                            'extern "C" int c_fn2(int x) {\n' + body(151) + "}\n"
                            "struct W {\n  W() : t_([this] { run(); }) {}\n  int operator()(int x) const {\n"
                            + body(151) + "  }\n};\nBENCH(f)->Args({1, 2})->Args({3, 4});\n",
        # Not searched.
        "tests/test_long.cpp": "void t() {\n" + body(300) + "}\n",
        "build/gen.cpp": "void g() {\n" + body(300) + "}\n",
        # Exactly the limit is fine.
        "analysis/edge.cpp": "int edge()\n{\n" + body(148) + "}\n",
    }
    expected = {
        "core/long.cpp:3: long_one: 160 lines",
        "scene/tricky.cpp:8: e: 153 lines",
        "precompute/lam.cpp:1: outer: 154 lines",
        "precompute/lam.cpp:155: ns_lambda (lambda): 157 lines",
        "include/prt/cls.h:3: Box::Box: 153 lines",
        "include/prt/cls.h:156: Box::operator=: 163 lines",
        "runtime/more.cpp:2: c_fn: 153 lines",
        "runtime/more.cpp:156: c_fn2: 153 lines",
        "runtime/more.cpp:311: W::operator(): 153 lines",
    }
    failures = []
    with tempfile.TemporaryDirectory() as tmp:
        root = pathlib.Path(tmp)
        for rel, text in files.items():
            (root / rel).parent.mkdir(parents=True, exist_ok=True)
            (root / rel).write_text(text, encoding="utf-8")
        got = set(check(root, DEFAULT_LIMIT))
        for line in sorted(expected - got):
            failures.append(f"missing: {line}")
        for line in sorted(got - expected):
            failures.append(f"unexpected: {line}")
        rows, _ = scan(root)
        short = {(r[1], r[3]): r[0] for r in rows}
        for key, length in {("core/long.cpp", "short_one"): 1, ("scene/tricky.cpp", "s"): 3,
                            ("scene/tricky.cpp", "c"): 1, ("scene/tricky.cpp", "d"): 1,
                            ("analysis/edge.cpp", "edge"): 150, ("runtime/more.cpp", "W::W"): 1}.items():
            if short.get(key) != length:
                failures.append(f"{key[0]}: {key[1]} measured {short.get(key)} lines, expected {length}")
        if check(root, 1000):
            failures.append(f"--limit 1000 still reports: {check(root, 1000)}")
        # An unbalanced file is reported, not skipped.
        (root / "runtime/broken.cpp").write_text("void f() {\n", encoding="utf-8")
        if not any("runtime/broken.cpp" in line for line in check(root, DEFAULT_LIMIT)):
            failures.append("an unbalanced file went unreported")
    for f in failures:
        print(f"self-test: {f}")
    print("self-test: " + ("FAILED" if failures else "ok"))
    return 1 if failures else 0


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("root", nargs="?", default=str(pathlib.Path(__file__).resolve().parent.parent))
    ap.add_argument("--limit", type=int, default=DEFAULT_LIMIT)
    ap.add_argument("--list", action="store_true", help=f"print the {LIST_COUNT} longest functions")
    ap.add_argument("--self-test", action="store_true")
    args = ap.parse_args()
    if args.self_test:
        return self_test()
    root = pathlib.Path(args.root)
    if args.list:
        rows, broken = scan(root)
        for length, path, line, name in sorted(rows, key=lambda r: (-r[0], r[1], r[2]))[:LIST_COUNT]:
            print(f"{path}:{line}: {name}: {length} lines")
        for path in broken:
            print(f"{path}: braces do not balance (the scanner cannot measure this file)")
        return 0
    lines = check(root, args.limit)
    for line in lines:
        print(line)
    return 1 if lines else 0


if __name__ == "__main__":
    sys.exit(main())
