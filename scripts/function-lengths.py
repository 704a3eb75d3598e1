#!/usr/bin/python3
"""Lists C++ functions longer than N lines, and files longer than a budget.

usage: function-lengths.py [--max N] [--max-file-lines M [--ceilings FILE]] [--fail] PATH...

PATHs are files or directories (searched for .cpp, .cc, .hpp, .h). A
function is found by brace matching, not by parsing C++: a `{` at namespace
or class scope whose preceding text ends a signature (`...)`, optionally
followed by const, noexcept, override, final or a trailing return type)
opens a function, which ends at its matching `}`. Comments, string and
character literals are skipped; braces of initialiser lists and aggregate
initialisers are not functions. Length counts the lines from the signature's
`{` line to the closing `}` line, both included.

With --max-file-lines, a file of more lines than M is over the budget too,
unless the --ceilings file lists it ("PATH LINES" a line, PATH relative to the
repository, '#' comments): a listed file may shrink but not grow past its
ceiling. The list holds the files that were over the budget when it came in
(to be split, not to be joined).

Prints one line per function or file over the limit (path:line: name: N
lines; path: N lines) and a summary. Exit status: 1 with --fail when any is
over, else 0 (2 on a usage error).
"""

import argparse
import os
import re
import sys

EXTENSIONS = (".cpp", ".cc", ".cxx", ".hpp", ".h", ".hh")
CONTAINER = re.compile(r"(^|[\s;}])(namespace|class|struct|union|enum)\b[^()]*$|extern\s+\"C\"\s*$")
SIGNATURE_END = re.compile(
    r"\)\s*((const|noexcept|override|final|mutable|volatile|&&?|noexcept\s*\([^()]*\)|->\s*[\w:<>,\s*&]+)\s*)*$"
)


def strip(text):
    """Blanks comments, string and character literals and preprocessor lines, keeping newlines."""
    out = []
    i, n = 0, len(text)
    line_start = True
    while i < n:
        c = text[i]
        if line_start and c in " \t":
            out.append(c)
            i += 1
            continue
        if line_start and c == "#":  # preprocessor line, with continuations
            while i < n and text[i] != "\n":
                if text[i] == "\\" and i + 1 < n and text[i + 1] == "\n":
                    out.append("\n")
                    i += 2
                    continue
                i += 1
            continue
        line_start = c == "\n"
        if text.startswith("//", i):
            while i < n and text[i] != "\n":
                i += 1
            continue
        if text.startswith("/*", i):
            end = text.find("*/", i + 2)
            end = n if end < 0 else end + 2
            out.append("".join(ch if ch == "\n" else " " for ch in text[i:end]))
            i = end
            continue
        m = re.match(r'(u8|u|U|L)?R"([^()\\\s]{0,16})\(', text[i:i + 24])
        if m and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == "_")):
            close = ")" + m.group(2) + '"'
            end = text.find(close, i + m.end())
            end = n if end < 0 else end + len(close)
            out.append('""' + "".join("\n" for ch in text[i:end] if ch == "\n"))
            i = end
            continue
        if c == '"' or (c == "'" and not (i > 0 and text[i - 1].isalnum() and i + 1 < n and text[i + 1].isalnum())):
            j = i + 1
            while j < n and text[j] != c and text[j] != "\n":
                j += 2 if text[j] == "\\" else 1
            out.append(c + c)
            i = j + 1
            continue
        out.append(c)
        i += 1
    return "".join(out)


def function_name(signature):
    head = signature.split("(")[0] if not re.search(r"operator\s*\(\)", signature) else signature
    m = re.search(r"operator\s*\S+?\s*(?=\()", signature)
    if m:
        names = re.findall(r"[\w:~]+", signature[: m.start()])
        return (names[-1] + "::" if names and names[-1].endswith("::") else "") + m.group(0).strip()
    names = re.findall(r"[~\w]+(?:::[~\w]+)*", head)
    return names[-1] if names else "?"


def functions(text):
    """Yields (name, first line, last line) of every function in stripped text."""
    stack = []  # kinds of the open blocks: 'container', 'function', 'init', 'block'
    buf = []  # text since the last statement or block boundary, at container scope
    line = 1
    start = None  # (name, line) of the open function
    for c in text:
        if c == "\n":
            line += 1
        in_container = all(k == "container" for k in stack)
        if c == "{":
            if not in_container:
                stack.append("block")
                continue
            prefix = " ".join("".join(buf).split())
            if prefix.count("(") > prefix.count(")"):
                stack.append("init")  # braces inside a parameter list: a default argument `= {}`
                buf.append(c)
            elif CONTAINER.search(prefix):
                stack.append("container")
                buf = []
            elif re.search(r"(=|return|\[\])\s*$", prefix) or re.search(r"=\s*[^()]*$", prefix):
                stack.append("block")  # aggregate initialiser or lambda at namespace scope
                buf = []
            elif "(" in prefix and SIGNATURE_END.search(prefix):
                stack.append("function")
                start = (function_name(prefix), line)
                buf = []
            elif re.search(r"[\w>]\s*$", prefix) and re.search(r"\)\s*:[^:]", prefix):
                stack.append("init")  # member{...} in a constructor's initialiser list
                buf.append(c)
            else:
                stack.append("block")
                buf = []
            continue
        if c == "}":
            kind = stack.pop() if stack else "block"
            if kind == "function" and start:
                yield start[0], start[1], line
                start = None
            if kind == "init":
                buf.append(c)
            else:
                buf = []
            continue
        if in_container:
            if c == ";":
                buf = []
            else:
                buf.append(c)


def sources(paths):
    for p in paths:
        if os.path.isdir(p):
            for root, dirs, files in os.walk(p):
                dirs.sort()
                for f in sorted(files):
                    if f.endswith(EXTENSIONS):
                        yield os.path.join(root, f)
        else:
            yield p


def main():
    ap = argparse.ArgumentParser(description="List C++ functions longer than N lines.")
    ap.add_argument("--max", type=int, default=100, help="longest allowed function, in lines (default 100)")
    ap.add_argument("--max-file-lines", type=int, default=0, help="longest allowed file, in lines (0: no budget)")
    ap.add_argument("--ceilings", help="files allowed over the budget, each with the most lines it may have")
    ap.add_argument("--fail", action="store_true", help="exit 1 when a function or file is longer")
    ap.add_argument("paths", nargs="+")
    args = ap.parse_args()
    ceilings = {}
    if args.ceilings:
        root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        with open(args.ceilings, encoding="utf-8") as f:
            for line in f:
                line = line.split("#", 1)[0].split()
                if len(line) == 2:
                    ceilings[os.path.normpath(os.path.join(root, line[0]))] = int(line[1])
    over, big, count, files = [], [], 0, 0
    for path in sources(args.paths):
        try:
            with open(path, encoding="utf-8", errors="replace") as f:
                raw = f.read()
        except OSError as e:
            print(f"function-lengths: {path}: {e.strerror}", file=sys.stderr)
            return 2
        text = strip(raw)
        files += 1
        lines = raw.count("\n")
        limit = ceilings.get(os.path.normpath(os.path.abspath(path)), args.max_file_lines)
        if args.max_file_lines and lines > limit:
            big.append((path, lines, limit))
        for name, first, last in functions(text):
            count += 1
            if last - first + 1 > args.max:
                over.append((path, first, name, last - first + 1))
    for path, first, name, n in over:
        print(f"{path}:{first}: {name}: {n} lines")
    for path, n, limit in big:
        print(f"{path}: {n} lines, over {'its ceiling of' if limit != args.max_file_lines else 'the budget of'} {limit}")
    print(f"function-lengths: {len(over)} of {count} functions in {files} files over {args.max} lines")
    if args.max_file_lines:
        print(f"function-lengths: {len(big)} of {files} files over {args.max_file_lines} lines "
              f"({len(ceilings)} with a ceiling)")
    return 1 if (over or big) and args.fail else 0


if __name__ == "__main__":
    sys.exit(main())
