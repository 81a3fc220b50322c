#!/usr/bin/env python3
"""No function in ref/, variants/ or python/ (.cpp, .hpp) longer than 150 lines (issue 62, STYLE.md:
functions read as a sequence of named stages). A function's length is the lines from its opening
brace to its closing one; a lambda counts toward the function it is written in, and class and
namespace bodies are not functions. A longer function passes only when the line directly before
its signature, or its leading comment block, says why: `function-length: <reason>`.
Exit 1 naming every function over the limit without a reason.
    function_length_test.py <source dir>   check the tree
    function_length_test.py --self-test    check the checker on made-up sources (it must catch a long
                                           function, and not be misled by comments, literals,
                                           lambdas, classes, namespaces or initializer lists)"""
import bisect
import pathlib
import re
import sys

LIMIT = 150
ROOTS = ("ref", "variants", "python")
MARKER = re.compile(r"function-length:\s*(\S.*)")

IDENT = re.compile(r"[A-Za-z0-9_]")
RAW_PREFIXES = ("R", "LR", "uR", "UR", "u8R")


def blank(text):
    """Spaces for every character but newlines: positions and line numbers stay where they were."""
    return re.sub(r"[^\n]", " ", text)


def token_before(src, i):
    """The identifier or number that ends just before src[i] ('' if none)."""
    j = i
    while j > 0 and (IDENT.match(src[j - 1]) or src[j - 1] in ".'"):
        j -= 1
    return src[j:i]



def logical_line_end(src, i):
    """Where the line from i ends, a line ending in a backslash going on into the next."""
    j = i
    while True:
        k = src.find("\n", j)
        if k < 0:
            return len(src)
        if src[k - 1] != "\\":
            return k
        j = k + 1

def strip_code(src):
    """src with comments, string and character literals and preprocessor lines blanked (a literal
    keeps its quotes, so `x = "";` still reads as an expression); same length, same lines."""
    out = []
    i, n = 0, len(src)
    line_start = True
    while i < n:
        c = src[i]
        if c == "\n":
            out.append(c)
            i += 1
            line_start = True
            continue
        if line_start and c in " \t":
            out.append(c)
            i += 1
            continue
        if line_start and c == "#":  # a directive, with its continuation lines
            k = logical_line_end(src, i)
            out.append(blank(src[i:k]))
            i = k
            continue
        line_start = False
        if src.startswith("//", i):  # a line comment ending in a backslash goes on
            k = logical_line_end(src, i)
            out.append(blank(src[i:k]))
            i = k
            continue
        if src.startswith("/*", i):
            k = src.find("*/", i + 2)
            k = n if k < 0 else k + 2
            out.append(blank(src[i:k]))
            i = k
            continue
        if c == '"':
            prefix = token_before(src, i)
            m = re.match(r'"([^()\\\s]{0,16})\(', src[i:i + 20]) if prefix in RAW_PREFIXES else None
            if m:  # raw string: R"delim( ... )delim"
                end = ")" + m.group(1) + '"'
                k = src.find(end, i + len(m.group(0)))
                k = n if k < 0 else k + len(end)
            else:
                k = quoted_end(src, i)
            out.append('"' + blank(src[i + 1:k - 1]) + ('"' if k - i > 1 else ""))
            i = k
            continue
        if c == "'":
            before = token_before(src, i)
            if before and (before[0].isdigit() or (before[0] == "." and before[1:2].isdigit())):
                out.append(c)  # a digit separator: 1'000'000
                i += 1
                continue
            k = quoted_end(src, i)
            out.append("'" + blank(src[i + 1:k - 1]) + ("'" if k - i > 1 else ""))
            i = k
            continue
        out.append(c)
        i += 1
    return "".join(out)


def quoted_end(src, i):
    """The index just past the string or character literal opening at src[i] (its quote), or past
    the end of its line when it is unterminated."""
    k = i + 1
    while k < len(src) and src[k] != src[i] and src[k] != "\n":
        k += 2 if src[k] == "\\" else 1
    return min(k + 1, len(src))


def matching(code, i, open_ch, close_ch):
    """The index of the bracket closing the one at code[i] (len(code) if unclosed)."""
    depth = 0
    for k in range(i, len(code)):
        if code[k] == open_ch:
            depth += 1
        elif code[k] == close_ch:
            depth -= 1
            if depth == 0:
                return k
    return len(code)


def opening(code, i, open_ch, close_ch):
    """The index of the bracket opening the one at code[i] (-1 if none)."""
    depth = 0
    for k in range(i, -1, -1):
        if code[k] == close_ch:
            depth += 1
        elif code[k] == open_ch:
            depth -= 1
            if depth == 0:
                return k
    return -1


QUALIFIERS = ("const", "volatile", "override", "final", "mutable", "constexpr", "consteval", "try", "noexcept", "&")


def without_trailing(h, words):
    """h without the words (and noexcept(...)) it ends with. A loop, not a regex: a pattern
    anchored at the end backtracks quadratically on long heads."""
    h = h.rstrip()
    while True:
        for w in words:
            if h.endswith(w) and (w == "&" or len(h) == len(w) or not IDENT.match(h[-len(w) - 1])):
                h = h[:-len(w)].rstrip()
                break
        else:
            if "noexcept" in words and h.endswith(")"):
                o = opening(h, len(h) - 1, "(", ")")
                before = h[:o].rstrip() if o >= 0 else ""
                if before.endswith("noexcept") and (len(before) == 8 or not IDENT.match(before[-9])):
                    h = before[:-8].rstrip()
                    continue
            return h


def ends_like_a_call(head):
    """The index of the ')' closing a parameter list that `head` ends with (after qualifiers, a
    trailing return type or a requires clause), or -1."""
    h = head.rstrip()
    arrow = h.rfind("->")
    if arrow >= 0 and ")" in h[:arrow] and not re.search(r"[;{}]", h[arrow:]):
        h = h[:arrow].rstrip()  # a trailing return type
    req = re.search(r"\brequires\b[^()]*(?:\([^()]*\))?[^()]*$", h)
    if req and ")" in h[:req.start()]:
        h = h[:req.start()].rstrip()
    h = without_trailing(h, QUALIFIERS)
    return len(h) - 1 if h.endswith(")") else -1


def is_lambda(head):
    """`head` ends with a lambda's introducer: [captures](params) specifiers, or [captures]."""
    h = head.rstrip()
    close = ends_like_a_call(h)
    if close >= 0:
        o = opening(h, close, "(", ")")
        h = h[:o].rstrip()
        h = re.sub(r"<[^<>]*>$", "", h).rstrip()  # []<class T>(...)
    else:
        h = without_trailing(h, ("mutable", "constexpr", "noexcept"))
        arrow = h.rfind("->")
        if arrow >= 0 and h[:arrow].rstrip().endswith("]"):
            h = h[:arrow].rstrip()
    if not h.endswith("]"):
        return False
    o = opening(h, len(h) - 1, "[", "]")
    if o < 0:
        return False
    before = h[:o].rstrip()
    # A subscript or an array's extent follows a name or a bracket; a lambda follows an operator,
    # a separator, `return`, or nothing.
    return not before or not (IDENT.match(before[-1]) or before[-1] in ")]") or re.search(r"\breturn$", before) is not None


MEMBER_INITIALIZERS = re.compile(r"\)\s*(?:noexcept\s*(?:\([^()]*\))?\s*)?:(?!:)")


def declarator_name(head):
    """The function's name for the message: what stands before its parameter list."""
    h = " ".join(head.split())
    if is_lambda(h):
        m = re.search(r"(\w+)\s*=\s*\[", h)
        return m.group(1) if m else "lambda"
    m = MEMBER_INITIALIZERS.search(h)
    if m:
        h = h[:m.start() + 1]
    close = ends_like_a_call(h)
    if close < 0:
        return h[-80:]
    o = opening(h, close, "(", ")")
    before = h[:o].rstrip()[-200:]
    m = re.search(r"(operator\s*(?:\(\)|\[\]|[^\s\w(]+)|~?[A-Za-z_][\w:~<>]*)$", before)
    if m and m.group(1).startswith("operator"):
        return m.group(1)
    m = re.search(r"((?:[A-Za-z_]\w*(?:<[^()]*?>)?::)*~?[A-Za-z_]\w*)$", before)
    return m.group(1) if m else (before[-60:] or "lambda")


def classify(head):
    """What a '{' at namespace or class scope opens, from the text since the last ';', '{' or '}'."""
    h = re.sub(r"^\s*(?:(?:public|private|protected)\s*:\s*)+", "", head)
    if re.search(r"\bnamespace\b", h) or re.match(r'\s*extern\s*"\s*"\s*$', h):
        return "namespace"
    if re.search(r"\bconcept\b", h) or re.search(r"\benum\b", h):
        return "other"
    if ends_like_a_call(h) >= 0 or is_lambda(h):
        return "function"
    if MEMBER_INITIALIZERS.search(h) and h.rstrip().endswith(("}", ")")):
        return "function"  # a constructor, after its member initializers
    # A class body: its key outside template arguments.
    depth = 0
    for m in re.finditer(r"[<>]|\b(?:class|struct|union)\b", h):
        t = m.group(0)
        if t == "<":
            depth += 1
        elif t == ">":
            depth = max(0, depth - 1)
        elif depth == 0:
            return "class"
    return "other"


def in_member_initializers(head):
    """`head` is a constructor's signature and initializer list, ending with a member's name:
    the '{' after it initializes that member, inside the list."""
    m = MEMBER_INITIALIZERS.search(head)
    if not m or re.search(r"\bcase\b|\?", head[m.end():]):
        return False
    member = head[m.end():].split(",")[-1]
    return re.fullmatch(r"\s*[\w:]+(?:<[\w:<> ]*>)?\s*", member) is not None


def functions_in(src):
    """Every function of `src`: (first line of its signature, name, lines from '{' to '}')."""
    code = strip_code(src)
    found = []  # [first line of the signature, name, line of '{', line of '}']
    line_starts = [0] + [m.end() for m in re.finditer("\n", code)]
    line_of = lambda pos: bisect.bisect_right(line_starts, pos)

    def scan(begin, end, initializer=False):
        """Namespace or class scope (or, with initializer, inside an initializer at such a scope)."""
        head_start = begin
        i = begin
        while i < end:
            c = code[i]
            if c in ";}" or (initializer and c == ","):
                head_start = i + 1
            elif c == "{":
                head = code[head_start:i]
                close = matching(code, i, "{", "}")
                if initializer:
                    kind = "function" if is_lambda(head) else "other"
                elif head.count("(") > head.count(")") or in_member_initializers(head):
                    kind = "in the signature"  # a default argument's braces, a member's initializer
                elif re.match(r"\s*catch\b", head) and found:
                    kind = "handler"  # of a function-try-block: the function goes on to its end
                else:
                    kind = classify(head)
                if kind == "function":
                    sig = head_start + (len(head) - len(head.lstrip()))
                    found.append([line_of(sig), declarator_name(head), line_of(i), line_of(close)])
                elif kind == "handler":
                    found[-1][3] = line_of(close)
                elif kind in ("namespace", "class"):
                    scan(i + 1, close)
                elif kind == "other":
                    scan(i + 1, close, initializer=True)
                i = close
                if kind != "in the signature":
                    head_start = close + 1
            i += 1

    scan(0, len(code))
    return [(sig, name, last - first + 1) for sig, name, first, last in found]


def reason_for(lines, signature_line):
    """The reason given directly above a function's signature (the line before it, or its leading
    comment block), or None. `lines` are the file's, signature_line 1-based."""
    k = signature_line - 2
    code_lines = None
    while k >= 0:
        text = lines[k].strip()
        if not text:
            return None
        m = MARKER.search(text)
        if m and len(m.group(1).split()) >= 2:
            return m.group(1).strip()
        if code_lines is None:
            code_lines = strip_code("\n".join(lines)).split("\n")
        if code_lines[k].strip():  # code, not comment: the comment block ended
            return None
        k -= 1
    return None


def problems_in(top):
    """Every function over LIMIT without a reason, and how many functions were measured."""
    problems, measured = [], 0
    for root in ROOTS:
        for f in sorted((top / root).rglob("*.[hc]pp")):
            src = f.read_text()
            lines = src.split("\n")
            for line, name, length in functions_in(src):
                measured += 1
                if length > LIMIT and reason_for(lines, line) is None:
                    problems.append(f"{f.relative_to(top).as_posix()}:{line}: {name} is {length} lines (limit {LIMIT}): split it into "
                                    "named stages, or say why not on the line before it (// function-length: <reason>)")
    if measured == 0:
        problems.append(f"no function found under {', '.join(ROOTS)}")
    return problems, measured


def body(lines, fill="  x += 1;"):
    return "\n".join([fill] * lines)


def self_test():
    """Made-up sources whose functions and lengths are known: the checker must find exactly those."""
    long_body, short_body = body(LIMIT + 10), body(LIMIT - 2)
    cases = [  # (what it checks, source, expected [(name, length)], expected names flagged)
        ("a long function", f"void f() {{\n{long_body}\n}}\n", [("f", LIMIT + 12)], ["f"]),
        ("one at the limit", f"void f() {{\n{short_body}\n}}\n", [("f", LIMIT)], []),
        ("one line over", f"void f() {{\n{short_body}\n x;\n}}\n", [("f", LIMIT + 1)], ["f"]),
        ("a reason on the line before", f"// function-length: the hot loop has no calls\nvoid f() {{\n{long_body}\n}}\n",
         [("f", LIMIT + 12)], []),
        ("a reason atop its comment block",
         f"// function-length: the hot loop has no calls\n// More on f.\ntemplate <class T>\nvoid f(T) {{\n{long_body}\n}}\n",
         [("f", LIMIT + 12)], []),
        ("a reason with no words", f"// function-length:\nvoid f() {{\n{long_body}\n}}\n", [("f", LIMIT + 12)], ["f"]),
        ("a reason a blank line away", f"// function-length: the hot loop has no calls\n\nvoid f() {{\n{long_body}\n}}\n",
         [("f", LIMIT + 12)], ["f"]),
        ("a reason on another function",
         f"// function-length: the hot loop has no calls\nvoid g() {{}}\nvoid f() {{\n{long_body}\n}}\n",
         [("g", 1), ("f", LIMIT + 12)], ["f"]),
        ("braces in comments and literals",
         "int f() {\n  // }\n  /* } { */\n  const char* s = \"}\\\"}\";\n  char c = '}', d = '\\'', e = '{';\n"
         "  auto r = R\"x(\")}\n}\n)x\";\n  auto u = u8R\"(})\";\n  return 1'000'000 + L'}';\n}\n"
         f"void g() {{\n{long_body}\n}}\n",
         [("f", 11), ("g", LIMIT + 12)], ["g"]),
        ("a lambda counts toward its function",
         f"void f() {{\n  const auto g = [&](int x) {{\n{long_body}\n  }};\n  g(1);\n}}\n", [("f", LIMIT + 15)], ["f"]),
        ("a class body is no function",
         f"struct s : base<int> {{\n  int a = 0;\n  void g() const {{ a; }}\n{body(LIMIT, '  int x;')}\n  struct t {{ int f() {{\n{long_body}\n}} }};\n}};\n",
         [("g", 1), ("f", LIMIT + 12)], ["f"]),
        ("a namespace is no function",
         f"namespace a {{\nnamespace {{\n{body(LIMIT, 'int x;')}\nvoid f() {{}}\n}}  // namespace\n}}\nextern \"C\" {{\nint h() {{ return 0; }}\n}}\n",
         [("f", 1), ("h", 1)], []),
        ("an initializer is no function, a lambda in it is",
         f"const std::vector<step> steps{{\n{body(LIMIT, '  {1, 2},')}\n  {{\"a\", [](int x) {{\n{long_body}\n  }}}},\n}};\n"
         "enum class e : int { a, b };\n",
         [("lambda", LIMIT + 12)], ["lambda"]),
        ("a constructor's member initializers",
         f"foo::foo(int a) noexcept : a_{{a}}, b_(a), c_<int>{{}} {{\n{long_body}\n}}\nint foo::get() const& {{ return a_; }}\n",
         [("foo::foo", LIMIT + 12), ("foo::get", 1)], ["foo::foo"]),
        ("braces in a default argument, a function-try-block",
         f"void f(std::vector<int> v = {{1, 2}},\n       int w = int{{3}}) try {{\n{long_body}\n}} catch (...) {{\n  x;\n}}\nint g() {{ return 1; }}\n",
         [("f", LIMIT + 14), ("g", 1)], ["f"]),
        ("qualifiers, trailing returns and macros",
         f"auto f(int a) -> std::vector<int> {{ return {{}}; }}\n#define OPEN {{\nbool operator()(int) const noexcept(true) {{ return true; }}\n"
         f"template <class T>\n  requires std::integral<T>\nT g(T t) {{ return t; }}\nTEST(suite, name) {{\n{long_body}\n}}\n",
         [("f", 1), ("operator()", 1), ("g", 1), ("TEST", LIMIT + 12)], ["TEST"]),
    ]
    failures = []
    for what, src, expected, flagged in cases:
        got = [(name, length) for _, name, length in functions_in(src)]
        lines = src.split("\n")
        got_flagged = [name for line, name, length in functions_in(src) if length > LIMIT and reason_for(lines, line) is None]
        if got != expected or got_flagged != flagged:
            failures.append(f"{what}: expected {expected}, flagged {flagged}; got {got}, flagged {got_flagged}")
    print("\n".join(failures) if failures else f"function-length self-test: {len(cases)} made-up sources, each measured right")
    return 1 if failures else 0


if __name__ == "__main__":
    if sys.argv[1:] == ["--self-test"]:
        sys.exit(self_test())
    problems, measured = problems_in(pathlib.Path(sys.argv[1]))
    print("\n".join(problems) if problems else f"function length: {measured} functions, none over {LIMIT} lines without a reason")
    sys.exit(1 if problems else 0)
