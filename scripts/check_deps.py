#!/usr/bin/env python3
"""Checks scripts/deps.txt, the list of what se3_sim takes from Debian (scripts/deps.sh installs
from it), two ways:

- declared: every program that the project's scripts (scripts/*.sh, .ci/run), Python tests and
  scripts (subprocess calls), launch and rostest files (launch-prefix, nodes of other packages),
  C++ tests and benchmarks (system, popen, exec*) and CMake rules (find_program, COMMAND) call,
  and every python3 module they import, is declared in scripts/deps.txt. A tool added to a
  script without its package fails here, on any machine, installed or not.
- installed: after scripts/deps.sh, every declared program of the levels given is on PATH, every
  module imports in /usr/bin/python3, every ROS package is found and every library package is
  installed.

Usage: scripts/check_deps.py [--levels base,test] [--no-installed] [--junit FILE]
       scripts/check_deps.py --test-env WS [--junit FILE]
Prints one line per problem (naming the file and line, or the Debian package to install) and
exits 1 on any; with --junit it writes check-deps.xml for scripts/test_summary.py. --test-env
checks a built workspace instead: that the environment ctest runs the rostests in imports the
generated se3_sim.msg and se3_sim.srv.
"""
import argparse
import ast
import glob
import os
import re
import shutil
import subprocess
import sys
import time
import xml.etree.ElementTree as ET
from xml.sax.saxutils import escape, quoteattr

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DEPS = os.path.join(REPO, 'scripts', 'deps.txt')
KINDS = ('cmd', 'py', 'ros', 'lib')

# Shell words that are not programs: bash's keywords and builtins.
SHELL_BUILTINS = set('''
if then else elif fi for in do done while until case esac function select time coproc
! [[ ]] { } [ : . source alias bg bind break builtin caller cd command compgen complete
continue declare dirs disown echo enable eval exec exit export false fc fg getopts hash help
history jobs kill let local logout mapfile popd printf pushd pwd read readarray readonly return
set shift shopt suspend test trap true type typeset ulimit umask unalias unset wait
'''.split())
# Words after which the next word is the program run: `nice -n 19 X`, `exec X`, `xargs ... X`.
PREFIXES = {'nice': {'-n'}, 'exec': set(), 'time': set(), 'env': set(),
            'xargs': {'-P', '-I', '-n', '-L', '-d', '-s', '-a', '-E'}}
# The project's own programs and modules, built here, not installed.
OWN_PY = {'se3_sim'}
# Python calls that take a program's argument list first.
RUNNERS = re.compile(r'^(run|Popen|call|check_call|check_output|start|spawn\w*|exec\w*)$')
CONT = '\x1f'  # stands for a backslash-newline: white space to str.split, a line to the count


def read_deps(path=DEPS):
    """[(level, kind, name, package, line number)] of scripts/deps.txt."""
    out = []
    for n, line in enumerate(open(path), 1):
        line = line.split('#', 1)[0].strip()
        if not line:
            continue
        f = line.split()
        if len(f) != 4 or f[1] not in KINDS:
            raise SystemExit('%s:%d: expected "level kind name package" (kind one of %s): %r'
                             % (path, n, ', '.join(KINDS), line))
        out.append((f[0], f[1], f[2], f[3], n))
    return out


# --- shell ---------------------------------------------------------------------------------------

def shell_code(text):
    """The text with quoted literals and parameter expansions replaced by the word @Q (no
    program's name), keeping what bash runs: command substitutions (in double quotes too), and
    single-quoted scripts given to `bash -c` or `trap` (with the single-quoted pieces glued to
    them). A code piece is cut off from the words around it by `; ... ; @Q`, so that the word
    after it is not taken for a program."""
    text = text.replace('\\\n', ' ' + CONT)
    out = []
    i, n = 0, len(text)
    code_sq_glue = False  # the last single-quoted piece was code and no blank came since

    def dq(i):  # i after the opening "; returns (code, index after the closing ")
        parts = []
        while i < n and text[i] != '"':
            if text[i] == '\\':
                i += 2
            elif text.startswith('$(', i) and not text.startswith('$((', i):
                body, i = subst(i + 2)
                parts.append(' ; ' + body + ' ; @Q')
            else:
                i += 1
        return ' @Q' + ''.join(parts), i + 1

    def subst(i):  # i after $( ; returns (code, index after the matching ))
        depth, start, parts = 1, i, []
        while i < n:
            c = text[i]
            if c == '\\':
                i += 2
                continue
            if c == '"':
                parts.append(text[start:i])
                body, i = dq(i + 1)
                parts.append(body)
                start = i
                continue
            if c == "'":
                j = text.find("'", i + 1)
                parts.append(text[start:i] + ' @Q ')
                i = start = (j + 1 if j >= 0 else n)
                continue
            if c == '(':
                depth += 1
            elif c == ')':
                depth -= 1
                if depth == 0:
                    parts.append(text[start:i])
                    return ''.join(parts), i + 1
            i += 1
        parts.append(text[start:])
        return ''.join(parts), n

    while i < n:
        c = text[i]
        if c == '\\':
            out.append(text[i:i + 2])
            i += 2
        elif c == '#' and (i == 0 or text[i - 1] in ' \t\n;'):
            j = text.find('\n', i)
            i = n if j < 0 else j
        elif c == '"':
            body, i = dq(i + 1)
            out.append(body)
        elif text.startswith('${', i):
            j = text.find('}', i)
            i = n if j < 0 else j + 1
            out.append('@Q')
        elif text.startswith('$(', i) and not text.startswith('$((', i):
            body, i = subst(i + 2)
            out.append(' @Q ; ' + body + ' ; @Q')
        elif c == "'":
            j = text.find("'", i + 1)
            j = n if j < 0 else j
            before = ''.join(out)[-12:]
            if code_sq_glue or re.search(r'(\bbash\s+-c|\btrap)\s+$', before):
                out.append(' ; ' + text[i + 1:j] + ' ; @Q')
                code_sq_glue = True
            else:
                out.append(' @Q ')
            i = j + 1
        else:
            if c in ' \t\n':
                code_sq_glue = False
            out.append(c)
            i += 1
    return ''.join(out)


def shell_commands(text):
    """[(line, program)] of the programs a bash script runs (a careful approximation: the first
    word of each simple command, after assignments and prefixes such as nice or xargs)."""
    code = shell_code(text)
    functions = set(re.findall(r'(?m)^\s*(?:function\s+)?([A-Za-z_][\w-]*)\s*\(\)', code))
    # arithmetic and tests hold no commands (their command substitutions are kept)
    code = re.sub(r'\$?\(\((?:[^()]|\([^()]*\))*\)\)', ' @Q ', code)
    # array assignments: name=( words ) holds no commands
    code = re.sub(r'\b([A-Za-z_]\w*\+?=)\([^()]*\)', r'\1@Q', code)
    # pieces, each starting at a command position (a line of `case` patterns ends at ')')
    pieces = re.split(r'(\n|;;|;|&&|\|\||\||&|\$\(|\(|\)|\{|\}|`|\bthen\b|\bdo\b|\belse\b|'
                      r'\bif\b|\belif\b|\bwhile\b|\buntil\b|!)', code)
    found = []
    line = 1
    for piece in pieces:
        words = piece.split()
        k = 0
        # skip assignments and prefixes
        while k < len(words):
            w = words[k]
            if re.match(r'^[A-Za-z_]\w*(\[[^]]*\])?\+?=', w):
                k += 1
            elif w in PREFIXES:
                opts = PREFIXES[w]
                k += 1
                while k < len(words) and (words[k].startswith('-') or '=' in words[k]):
                    k += 2 if words[k] in opts else 1
            else:
                break
        if k < len(words):
            w = words[k]
            if w in ('command', 'type', 'hash') or w in ('for', 'case', 'select', 'in'):
                pass  # `command -v X` looks a program up, it does not need it; loop words
            elif w.startswith('/') and re.match(r'^/(usr/)?(s?bin)/[\w.+-]+$', w):
                found.append((line, os.path.basename(w)))
            elif re.match(r'^[A-Za-z_][\w.+-]*$', w) and w not in SHELL_BUILTINS \
                    and w not in functions:
                found.append((line, w))
        line += piece.count('\n') + piece.count(CONT)
    # compilers named to CMake on the command line
    for m in re.finditer(r'-DCMAKE_(?:C|CXX)_COMPILER=([A-Za-z_][\w.+-]*)', code):
        found.append((code.count('\n', 0, m.start()) + code.count(CONT, 0, m.start()) + 1,
                      m.group(1)))
    return found


# --- python, launch files, C++, CMake ------------------------------------------------------------

def python_uses(path):
    """([(line, module)], [(line, program)]): the top-level modules imported, and the programs of
    calls that run one (subprocess.run, Popen, a helper named run or start, ...) whose argument
    list starts with a string."""
    tree = ast.parse(open(path).read(), path)
    here = {os.path.splitext(os.path.basename(p))[0]
            for p in glob.glob(os.path.join(os.path.dirname(path), '*.py'))}
    mods, cmds = [], []
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            mods += [(node.lineno, a.name.split('.')[0]) for a in node.names]
        elif isinstance(node, ast.ImportFrom) and node.level == 0 and node.module:
            mods.append((node.lineno, node.module.split('.')[0]))
        elif isinstance(node, ast.Call) and RUNNERS.match(
                    getattr(node.func, 'attr', getattr(node.func, 'id', ''))) \
                and node.args and isinstance(node.args[0], (ast.List, ast.Tuple)) \
                and node.args[0].elts and isinstance(node.args[0].elts[0], ast.Constant) \
                and isinstance(node.args[0].elts[0].value, str):
            cmds.append((node.lineno, os.path.basename(node.args[0].elts[0].value)))
    stdlib = set(sys.stdlib_module_names)
    mods = [(n, m) for n, m in mods if m not in stdlib and m not in here and m not in OWN_PY]
    return mods, cmds


def launch_uses(path):
    """([(program)], [(ros package)]) of a launch or rostest file: launch-prefix programs and the
    packages of nodes and tests that are not se3_sim."""
    root = ET.parse(path).getroot()
    cmds, pkgs = [], []
    for el in root.iter():
        if el.tag not in ('node', 'test'):
            continue
        pkg = el.get('pkg', '')
        if pkg and pkg != 'se3_sim' and not pkg.startswith('$'):
            pkgs.append(pkg)
        prefix = (el.get('launch-prefix') or '').split()
        if prefix and not prefix[0].startswith('$'):
            cmds.append(os.path.basename(prefix[0]))
    return cmds, pkgs


def cpp_uses(text):
    """[(line, program)] run by exec*/system/popen with a literal program name in C++."""
    out = []
    for m in re.finditer(r'\b(?:exec[lv]p?e?|posix_spawnp?)\s*\(\s*"([^"]+)"', text):
        out.append((text.count('\n', 0, m.start()) + 1, os.path.basename(m.group(1))))
    for m in re.finditer(r'\b(?:system|popen)\s*\(\s*\(?\s*(?:std::string\s*\(\s*)?"([^"]*)"', text):
        words = [w for w in m.group(1).split() if not re.match(r'^[A-Za-z_]\w*=', w)]
        if words and re.match(r'^[A-Za-z_][\w.+-]*$', words[0]):
            out.append((text.count('\n', 0, m.start()) + 1, words[0]))
    return out


def cmake_uses(text):
    out = []
    for m in re.finditer(r'(?i)\bfind_program\s*\(\s*\w+\s+(?:NAMES\s+)?([\w.+-]+)', text):
        out.append((text.count('\n', 0, m.start()) + 1, m.group(1)))
    for m in re.finditer(r'\bCOMMAND\s+([A-Za-z_][\w.+-]*)(?=\s)', text):
        out.append((text.count('\n', 0, m.start()) + 1, m.group(1)))
    return out


def project_files(pattern):
    return sorted(glob.glob(os.path.join(REPO, pattern), recursive=True))


def own_programs():
    """Programs the project builds or ships (a call to one needs no package)."""
    own = set()
    for f in project_files('CMakeLists.txt') + project_files('fuzz/CMakeLists.txt'):
        text = open(f).read()
        own |= set(re.findall(r'\b(?:add_executable|catkin_add_gtest|catkin_add_executable_with_gtest)'
                              r'\s*\(\s*([\w.+-]+)', text))
        own |= {os.path.splitext(os.path.basename(p))[0]
                for p in project_files('test/*.cpp') + project_files('fuzz/*.cpp')}
    own |= {os.path.basename(p) for p in project_files('scripts/*') + project_files('test/*.py')}
    return own


def declared_problems(deps):
    """One line per program called or module imported that deps.txt does not declare."""
    cmds = {name for _, kind, name, _, _ in deps if kind == 'cmd'}
    pys = {name for _, kind, name, _, _ in deps if kind == 'py'}
    ros = {name for _, kind, name, _, _ in deps if kind == 'ros'}
    own = own_programs()
    problems = []

    def need(kind, name, where):
        have = {'cmd': cmds, 'py': pys, 'ros': ros}[kind]
        if name not in have and not (kind == 'cmd' and name in own):
            what = {'cmd': 'calls the program', 'py': 'imports the python3 module',
                    'ros': 'uses the ROS package'}[kind]
            problems.append('%s: %s %r, which scripts/deps.txt does not declare (add "LEVEL %s %s '
                            'DEBIAN-PACKAGE")' % (where, what, name, kind, name))

    rel = lambda p: os.path.relpath(p, REPO)  # noqa: E731
    for f in project_files('scripts/*.sh') + project_files('.ci/run'):
        for line, c in shell_commands(open(f).read()):
            need('cmd', c, '%s:%d' % (rel(f), line))
    for f in project_files('scripts/*.py') + project_files('test/*.py'):
        mods, calls = python_uses(f)
        for line, m in mods:
            need('py', m, '%s:%d' % (rel(f), line))
        for line, c in calls:
            need('cmd', c, '%s:%d' % (rel(f), line))
    for f in project_files('launch/*.launch') + project_files('test/*.test'):
        calls, pkgs = launch_uses(f)
        for c in calls:
            need('cmd', c, rel(f))
        for p in pkgs:
            need('ros', p, rel(f))
    for f in (project_files('test/*.cpp') + project_files('test/*.h') + project_files('bench/*.cpp')
              + project_files('fuzz/*.cpp') + project_files('tools/**/*.cpp')
              + project_files('src/**/*.cpp')):
        for line, c in cpp_uses(open(f).read()):
            need('cmd', c, '%s:%d' % (rel(f), line))
    for f in project_files('CMakeLists.txt') + project_files('fuzz/CMakeLists.txt'):
        for line, c in cmake_uses(open(f).read()):
            need('cmd', c, '%s:%d' % (rel(f), line))
    def order(p):  # by file, then line number
        where = p.split(': ', 1)[0].split(':')
        return where[0], int(where[1]) if len(where) > 1 and where[1].isdigit() else 0, p
    return sorted(set(problems), key=order)


def installed_problems(deps, levels):
    """One line per declared need of the levels that this machine does not meet."""
    python = '/usr/bin/python3' if os.path.exists('/usr/bin/python3') else sys.executable
    problems = []
    mods = sorted({(name, pkg) for level, kind, name, pkg, _ in deps
                   if level in levels and kind == 'py'})
    rospkgs = sorted({(name, pkg) for level, kind, name, pkg, _ in deps
                      if level in levels and kind == 'ros'})
    for level, kind, name, pkg, n in deps:
        if level not in levels:
            continue
        if kind == 'cmd' and not shutil.which(name):
            problems.append('%s not found on PATH: install the Debian package %s '
                            '(scripts/deps.txt:%d, level %s)' % (name, pkg, n, level))
        elif kind == 'lib':
            r = subprocess.run(['dpkg-query', '-W', '-f=${Status}', pkg], capture_output=True,
                               text=True)
            if 'install ok installed' not in r.stdout:
                problems.append('the Debian package %s is not installed (scripts/deps.txt:%d, '
                                'level %s)' % (pkg, n, level))
    # one python3 for every module and ROS package: prints the ones that fail
    probe = ('import importlib, sys\n'
             'for m, p in %r:\n'
             '    try:\n'
             '        importlib.import_module(m)\n'
             '    except Exception as e:\n'
             '        print("python3 module %%s does not import (%%s): install the Debian package %%s" %% (m, e, p))\n'
             'if %r:\n'
             '    try:\n'
             '        import rospkg\n'
             '        rp = rospkg.RosPack()\n'
             '    except Exception as e:\n'
             '        rp = None\n'
             '        print("python3 module rospkg does not import (%%s), ROS packages not checked" %% e)\n'
             '    for r, p in %r:\n'
             '        try:\n'
             '            rp and rp.get_path(r)\n'
             '        except Exception:\n'
             '            print("ROS package %%s not found: install the Debian package %%s" %% (r, p))\n'
             % (mods, bool(rospkgs), rospkgs))
    r = subprocess.run([python, '-c', probe], capture_output=True, text=True)
    problems += [l for l in r.stdout.splitlines() if l.strip()]
    if r.returncode != 0:
        problems.append('%s could not run the module check: %s' % (python, r.stderr.strip()[-300:]))
    return problems


def test_env_problems(ws):
    """The rostests run in build/catkin_generated/env_cached.sh, which catkin writes when it
    configures: its PYTHONPATH must reach the generated se3_sim.msg and se3_sim.srv."""
    env = os.path.join(ws, 'build', 'catkin_generated', 'env_cached.sh')
    if not os.path.isfile(env):
        return ['%s is missing: the workspace is not configured' % env]
    r = subprocess.run([env, '/usr/bin/python3', '-c', 'import se3_sim.msg, se3_sim.srv'],
                       capture_output=True, text=True)
    if r.returncode != 0:
        last = (r.stderr.strip().splitlines() or ['exit %d' % r.returncode])[-1]
        return ['the tests\' environment (%s) cannot import the messages: %s' % (env, last)]
    return []


def junit(path, cases):
    """cases: [(name, seconds, problems)]"""
    os.makedirs(os.path.dirname(os.path.abspath(path)), exist_ok=True)
    failures = sum(1 for _, _, p in cases if p)
    with open(path, 'w') as f:
        f.write('<?xml version="1.0" encoding="UTF-8"?>\n')
        f.write('<testsuite name="deps" tests="%d" failures="%d">\n' % (len(cases), failures))
        for name, secs, problems in cases:
            f.write('  <testcase classname="Deps" name="%s" time="%.1f">' % (name, secs))
            if problems:
                msg = '%d problem%s: %s' % (len(problems), 's' if len(problems) > 1 else '',
                                            problems[0])
                f.write('\n    <failure message=%s>%s</failure>\n  ' % (
                    quoteattr(msg), escape('\n'.join(problems))))
            f.write('</testcase>\n')
        f.write('</testsuite>\n')


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n\n')[0])
    ap.add_argument('--levels', default='base,test',
                    help='levels of scripts/deps.txt whose install is checked (default base,test)')
    ap.add_argument('--no-installed', action='store_true',
                    help='only the declared check (nothing about this machine)')
    ap.add_argument('--junit', help='write the results as JUnit XML (check-deps.xml)')
    ap.add_argument('--test-env', metavar='WS',
                    help='only check that the environment ctest runs the tests in (the built '
                    'workspace WS) imports the generated messages')
    args = ap.parse_args()
    cases = []
    if args.test_env:
        t = time.time()
        cases.append(('TestEnvironmentImportsTheMessages', time.time() - t,
                      test_env_problems(args.test_env)))
        cases[-1] = (cases[-1][0], time.time() - t, cases[-1][2])
        return report(cases, args.junit)
    deps = read_deps()
    t = time.time()
    problems = declared_problems(deps)
    cases.append(('ScriptsAndTestsCallOnlyDeclaredPrograms', time.time() - t, problems))
    if not args.no_installed:
        t = time.time()
        levels = set(args.levels.split(','))
        cases.append(('DeclaredProgramsAndModulesAreInstalled', time.time() - t,
                      installed_problems(deps, levels)))
        cases[-1] = (cases[-1][0], time.time() - t, cases[-1][2])
    return report(cases, args.junit)


def report(cases, junit_path):
    bad = 0
    for name, _, problems in cases:
        for p in problems:
            print('se3_sim deps: %s' % p)
        print('Deps.%s: %s' % (name, 'failed (%d)' % len(problems) if problems else 'passed'))
        bad += bool(problems)
    if junit_path:
        junit(junit_path, cases)
    return 1 if bad else 0


if __name__ == '__main__':
    sys.exit(main())
