#!/usr/bin/env python3
"""List the longest functions of the C++ and Python sources under a folder.

A C++ function runs from the first line of its signature to its closing brace; a Python
function from its `def` line to its last line. Lambdas and local classes count as part of the
function around them; a class's inline member functions count one by one.

    scripts/function_lengths.py [ROOT] [--top N] [--over LINES]

With --over, exits 1 when a function is longer than LINES (a check for the whole tree).
"""
import argparse
import ast
import os
import re
import sys

CXX_EXTENSIONS = ('.cpp', '.cc', '.cxx', '.h', '.hpp')
SKIPPED_FOLDERS = {'build', 'devel', 'install', '.git', '__pycache__'}
CONTROL_KEYWORDS = {'if', 'for', 'while', 'switch', 'catch', 'do', 'else', 'try', 'return'}
SCOPE_KEYWORDS = re.compile(r'\b(namespace|class|struct|union|enum)\b')


def strip_cxx(text):
    """The text with comments, string and character literals blanked, newlines kept."""
    out = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if text.startswith('//', i):
            j = text.find('\n', i)
            j = n if j < 0 else j
            out.append(' ' * (j - i))
            i = j
        elif text.startswith('/*', i):
            j = text.find('*/', i + 2)
            j = n if j < 0 else j + 2
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
        elif text.startswith('R"', i) and (i == 0 or not (text[i - 1].isalnum() or text[i - 1] == '_')):
            open_paren = text.find('(', i)
            delimiter = text[i + 2:open_paren]
            j = text.find(')' + delimiter + '"', open_paren)
            j = n if j < 0 else j + len(delimiter) + 2
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
        elif c in '"\'':
            if c == "'" and i > 0 and text[i - 1].isalnum():  # digit separator 1'000
                out.append(' ')
                i += 1
                continue
            j = i + 1
            while j < n and text[j] != c:
                j += 2 if text[j] == '\\' else 1
            j = min(j + 1, n)
            out.append(re.sub(r'[^\n]', ' ', text[i:j]))
            i = j
        elif c == '#' and (i == 0 or text[i - 1] == '\n'):  # preprocessor line (and continuations)
            j = i
            while True:
                k = text.find('\n', j)
                if k < 0:
                    k = n
                    break
                if text[k - 1] != '\\':
                    break
                j = k + 1
            out.append(re.sub(r'[^\n]', ' ', text[i:k]))
            i = k
        else:
            out.append(c)
            i += 1
    return ''.join(out)


def cxx_functions(path):
    """(name, first line, last line) of each function body in one C++ file."""
    text = strip_cxx(open(path, encoding='utf-8', errors='replace').read())
    functions = []
    # Each open brace: ('scope' for namespaces, classes and initialisers, or 'function').
    stack = []
    header_start = 0  # where the text before the next brace starts
    line = 1
    header_line = None  # line of the header's first non-blank character
    function_start = None
    paren_depth = 0  # in a header: braces within parentheses (default arguments) open no scope
    for i, c in enumerate(text):
        if c == '\n':
            line += 1
            continue
        inside_function = any(kind == 'function' for kind, _, _ in stack)
        if not inside_function and c in '()':
            paren_depth = max(0, paren_depth + (1 if c == '(' else -1))
        if c in '{}' and not inside_function and paren_depth > 0:
            continue
        if c in ';{}' and not inside_function:
            if c == '{':
                header = text[header_start:i]
                kind = 'scope'
                name = None
                stripped = header.strip()
                match = re.search(r'([~\w:<>]+(?:operator\s*\S+?)?)\s*\(', stripped)
                if (stripped.endswith(')') or re.search(r'\)\s*(const|override|final|noexcept|mutable|'
                                                           r'->\s*[\w:<>,\s*&]+)\s*$', stripped)
                        or re.search(r'\)\s*:\s*\w', stripped)) and match \
                        and not SCOPE_KEYWORDS.match(stripped) \
                        and match.group(1).split('::')[-1] not in CONTROL_KEYWORDS \
                        and not stripped.startswith('='):
                    kind = 'function'
                    name = match.group(1)
                stack.append((kind, name, header_line if header_line is not None else line))
            elif c == '}':
                if stack:
                    stack.pop()
            header_start = i + 1
            header_line = None
            continue
        if c == '{':
            stack.append(('block', None, line))
        elif c == '}':
            kind, name, first = stack.pop()
            if kind == 'function':
                functions.append((name, first, line))
                header_start = i + 1
                header_line = None
        elif not inside_function and not c.isspace() and header_line is None:
            header_line = line
        if not inside_function and c == ':' and text[i - 1] != ':' and text[i + 1:i + 2] != ':':
            # "public:" and the like end a header
            before = text[header_start:i].strip()
            if before in ('public', 'private', 'protected'):
                header_start = i + 1
                header_line = None
    return functions


def python_functions(path):
    try:
        tree = ast.parse(open(path, encoding='utf-8').read(), path)
    except SyntaxError:
        return []
    functions = []

    def visit(node, prefix):
        for child in ast.iter_child_nodes(node):
            if isinstance(child, (ast.FunctionDef, ast.AsyncFunctionDef)):
                first = min([child.lineno] + [d.lineno for d in child.decorator_list])
                functions.append((prefix + child.name, first, child.end_lineno))
                # nested functions count as part of the function around them
            elif isinstance(child, ast.ClassDef):
                visit(child, prefix + child.name + '.')
            else:
                visit(child, prefix)

    visit(tree, '')
    return functions


def is_python(path):
    if path.endswith('.py'):
        return True
    if os.path.splitext(path)[1]:
        return False
    try:
        with open(path, encoding='utf-8') as f:
            return 'python' in f.readline()
    except (UnicodeDecodeError, OSError):
        return False


def all_functions(root):
    for folder, subfolders, files in os.walk(root):
        subfolders[:] = sorted(d for d in subfolders if d not in SKIPPED_FOLDERS)
        for name in sorted(files):
            path = os.path.join(folder, name)
            if name.endswith(CXX_EXTENSIONS):
                found = cxx_functions(path)
            elif is_python(path):
                found = python_functions(path)
            else:
                continue
            for function, first, last in found:
                yield last - first + 1, os.path.relpath(path, root), first, function


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument('root', nargs='?', default='catkin_ws/src')
    parser.add_argument('--top', type=int, default=10, help='how many to list (default 10)')
    parser.add_argument('--over', type=int, help='list every function longer than this, exit 1 if any')
    args = parser.parse_args()
    functions = sorted(all_functions(args.root), key=lambda f: (-f[0], f[1], f[2]))
    if args.over is not None:
        functions = [f for f in functions if f[0] > args.over]
    else:
        functions = functions[:args.top]
    for length, path, first, name in functions:
        print(f'{length:5d}  {path}:{first}  {name}')
    return 1 if args.over is not None and functions else 0


if __name__ == '__main__':
    sys.exit(main())
