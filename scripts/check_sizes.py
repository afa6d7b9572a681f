#!/usr/bin/python3
"""The size rules of the source (issue 56): no source file over 800 lines, and no product function over 120
lines outside tests, test benches (their vector tables) and the Python binding's module definition.
C++ functions are found by brace matching on the text without comments and literals, Python ones by ast.
Usage: scripts/check_sizes.py ROOT; exits 1 naming each file or function over its limit."""
import ast, os, re, sys

FUNCTION_LIMIT, FILE_LIMIT = 120, 800
root = sys.argv[1] if len(sys.argv) > 1 else "."
CTRL = re.compile(r'^\s*(if|for|while|switch|catch|else|do|return)\b')
TYPEKW = re.compile(r'\b(class|struct|namespace|enum|union)\b[^()]*$')

def strip(src):
    # blank out comments and string/char literals, keep newlines
    out = []; i = 0; n = len(src)
    while i < n:
        c = src[i]
        if src.startswith('//', i):
            j = src.find('\n', i); j = n if j < 0 else j
            out.append(' ' * (j - i)); i = j
        elif src.startswith('/*', i):
            j = src.find('*/', i + 2); j = n if j < 0 else j + 2
            out.append(re.sub(r'[^\n]', ' ', src[i:j])); i = j
        elif src.startswith('R"', i):
            m = re.match(r'R"([^(]*)\(', src[i:])
            if m:
                end = ')' + m.group(1) + '"'
                j = src.find(end, i); j = n if j < 0 else j + len(end)
                out.append(re.sub(r'[^\n]', ' ', src[i:j])); i = j
            else:
                out.append(c); i += 1
        elif c == '#' and (i == 0 or src[src.rfind('\n', 0, i) + 1:i].strip() == ''):
            j = i
            while True:
                k = src.find('\n', j); k = n if k < 0 else k
                if k > 0 and src[k - 1] == '\\' and k < n: j = k + 1; continue
                break
            out.append(re.sub(r'[^\n]', ' ', src[i:k])); i = k
        elif c in '"\'':
            if c == "'" and i > 0 and (src[i-1].isalnum()):  # digit separator 1'000
                out.append(' '); i += 1; continue
            j = i + 1
            while j < n and src[j] != c:
                j += 2 if src[j] == '\\' else 1
            out.append(' ' * (j + 1 - i)); i = j + 1
        else:
            out.append(c); i += 1
    return ''.join(out)

def cpp(path):
    src = strip(open(path, errors='replace').read())
    stack = []  # (is_fn, start_line, name)
    last = 0
    res = []
    for i, c in enumerate(src):
        if c == '{':
            head = src[last:i]
            h = ' '.join(head.split())
            is_fn = False; name = ''
            if ')' in h and not CTRL.match(h) and not TYPEKW.search(h.split('(')[0]) and not h.endswith('='):
                tail = h[h.rfind(')') + 1:]
                if re.fullmatch(r'\s*((const|noexcept|override|final|mutable|->\s*[\w:<>,\s*&]+)\s*)*', tail) or ':' in h:
                    m = re.search(r'([~\w:]+|\[[^\]]*\])\s*\(', h)
                    name = m.group(1) if m else h[:40]
                    is_fn = not name.startswith('[') or True
            # start line: first non-blank char of head
            k = last
            while k < i and src[k].isspace(): k += 1
            stack.append((is_fn and not any(s[0] for s in stack), src.count('\n', 0, k) + 1, name))
            last = i + 1
        elif c == '}':
            if stack:
                is_fn, start, name = stack.pop()
                if is_fn:
                    end = src.count('\n', 0, i) + 1
                    res.append((end - start + 1, start, name))
            last = i + 1
        elif c == ';':
            last = i + 1
    return res

def py(path):
    try:
        tree = ast.parse(open(path).read())
    except Exception:
        return []
    return [(n.end_lineno - n.lineno + 1, n.lineno, n.name) for n in ast.walk(tree)
            if isinstance(n, (ast.FunctionDef, ast.AsyncFunctionDef))]

# Where long functions are allowed: test cases and tools, test benches, the module definition of the bindings.
EXEMPT_DIRS = ('tests/', 'rtl_sim/tb/')
EXEMPT_NAMES = ('PYBIND11_MODULE',)
SKIP_DIRS = ('build', '.git', 'third_party')

bad = []
for d, dirs, files in os.walk(root):
    dirs[:] = [x for x in dirs if x not in SKIP_DIRS and not x.startswith('.')]
    for f in files:
        p = os.path.join(d, f)
        rel = os.path.relpath(p, root)
        if f.endswith(('.cpp', '.h', '.hpp', '.cc', '.sv')):
            r = cpp(p) if not f.endswith('.sv') else []
        elif f.endswith('.py'):
            r = py(p)
        else:
            continue
        lines = sum(1 for _ in open(p, errors='replace'))
        if lines > FILE_LIMIT:
            bad.append(f'{rel}: {lines} lines (at most {FILE_LIMIT})')
        if rel.startswith(EXEMPT_DIRS):
            continue
        for ln, start, name in r:
            if ln > FUNCTION_LIMIT and name not in EXEMPT_NAMES:
                bad.append(f'{rel}:{start}: function {name} is {ln} lines (at most {FUNCTION_LIMIT})')
for b in sorted(bad):
    print('check_sizes:', b)
sys.exit(1 if bad else 0)
