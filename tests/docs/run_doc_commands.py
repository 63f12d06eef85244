#!/usr/bin/python3
"""Runs the docs' runnable code blocks and checks every link of the docs.

The convention (docs/testing.md, "The docs' commands"): a fenced block whose
info string is `sh` or `python`, preceded by the HTML comment

    <!-- doc-test -->            run the block
    <!-- doc-test: server -->    start each line of the block in the background
                                 (tribod, tribo-bench), as a second terminal would
    <!-- doc-test: dask-cluster -->  run the block with a scheduler and a worker
                                 of Dask on 127.0.0.1, its address in $DASK_SCHEDULER

Each page runs in its own scratch directory that looks like a checkout: the
source tree's top-level entries linked in, `config/` copied, `build/` the build
tree. Its blocks run in order, as one terminal session would run them: a shell
block's exported variables and working directory carry over to the next block,
a python block runs with /usr/bin/python3 in that environment. Servers get
`--port 0` (a free port on 127.0.0.1): the address tribod prints goes into
$TRIBO_ADDRESS, which `tribo` reads, and the port tribo-bench prints replaces
the Modbus port of the page's copies of config/*.textproto. Everything started
is stopped at the end of the page. A block that fails fails the test.

The link check reads every Markdown file of the source tree: each relative
link and image must name a file that exists and, with #anchor, a heading of
that file; each repository path a page quotes (`config/x.textproto`, or
docs/x.md in the text) must exist; each section a file of the tree names by
page and title (docs/x.md, "Title") must be a heading or a paragraph label
(**Title.**) of that page.

    run_doc_commands.py --build-dir BUILD --source-dir SRC [--keep] [--links-only|--no-links] [PAGE.md ...]
"""

import argparse
import os
import re
import shutil
import signal
import subprocess
import sys
import tempfile
import time

MARKER = re.compile(r"^<!--\s*doc-test(?::\s*([\w-]+))?\s*-->\s*$")
FENCE = re.compile(r"^(```+|~~~+)\s*([\w+-]*)")
BLOCK_TIMEOUT_S = 300
SERVER_START_TIMEOUT_S = 60


# ---------------------------------------------------------------- blocks

def runnable_blocks(path):
    """(kind, language, code, line) for every marked block of a page."""
    lines = open(path, encoding="utf-8").read().splitlines()
    blocks, i = [], 0
    while i < len(lines):
        m = MARKER.match(lines[i].strip())
        if not m:
            i += 1
            continue
        kind, start = m.group(1) or "run", i + 1
        j = i + 1
        while j < len(lines) and not lines[j].strip():
            j += 1
        fence = FENCE.match(lines[j]) if j < len(lines) else None
        if not fence or fence.group(2) not in ("sh", "python"):
            raise SystemExit(f"{path}:{start}: <!-- doc-test --> is not followed by a sh or python block")
        if kind not in ("run", "server", "dask-cluster"):
            raise SystemExit(f"{path}:{start}: unknown doc-test kind '{kind}'")
        if kind == "server" and fence.group(2) != "sh":
            raise SystemExit(f"{path}:{start}: a server block is a sh block")
        k = j + 1
        while k < len(lines) and not lines[k].startswith(fence.group(1)):
            k += 1
        if k == len(lines):
            raise SystemExit(f"{path}:{j + 1}: unclosed code block")
        blocks.append((kind, fence.group(2), "\n".join(lines[j + 1:k]) + "\n", j + 1))
        i = k + 1
    return blocks


class Page:
    """A page's terminal session: scratch directory, environment, servers."""

    def __init__(self, page, source_dir, build_dir, keep):
        self.page = page
        self.keep = keep
        self.servers = []
        self.dir = tempfile.mkdtemp(prefix="doc-test-")
        for entry in os.listdir(source_dir):
            if entry in ("build", ".git", "config") or entry.startswith("build-"):
                continue
            os.symlink(os.path.join(source_dir, entry), os.path.join(self.dir, entry))
        shutil.copytree(os.path.join(source_dir, "config"), os.path.join(self.dir, "config"))
        os.symlink(build_dir, os.path.join(self.dir, "build"))
        self.cwd = self.dir
        self.env = {k: v for k, v in os.environ.items()
                    if k not in ("TRIBO_ADDRESS", "TRIBO_TOKEN", "TRIBOD_CONTROL_TOKEN",
                                 "PYTHONPATH", "DASK_SCHEDULER")}
        self.env["MPLCONFIGDIR"] = os.path.join(self.dir, ".mplconfig")
        self.env["MPLBACKEND"] = "Agg"
        self.env["COLUMNS"] = "100"

    def run(self, kind, language, code, line):
        where = f"{self.page}:{line}"
        if kind == "server":
            for command in code.splitlines():
                command = command.split("#")[0].strip().rstrip("&").strip()
                if command:
                    self.start_server(command, where)
            return
        if kind == "dask-cluster":
            self.start_dask_cluster(where)
        if language == "python":
            script = os.path.join(self.dir, ".block.py")
            open(script, "w").write(code)
            self.call(["/usr/bin/python3", script], code, where)
            return
        script = os.path.join(self.dir, ".block.sh")
        state = os.path.join(self.dir, ".state")
        open(script, "w").write(
            "set -euo pipefail\n" + code +
            f"\npwd > '{state}.cwd'\nenv -0 > '{state}.env'\n")
        self.call(["bash", script], code, where)
        self.cwd = open(state + ".cwd").read().strip()
        raw = open(state + ".env", "rb").read().decode()
        self.env = dict(item.split("=", 1) for item in raw.split("\0") if "=" in item)

    def call(self, argv, code, where):
        print(f"--- {where}\n{code}", end="", flush=True)
        started = time.monotonic()
        try:
            done = subprocess.run(argv, cwd=self.cwd, env=self.env, stdout=subprocess.PIPE,
                                  stderr=subprocess.STDOUT, timeout=BLOCK_TIMEOUT_S)
        except subprocess.TimeoutExpired as e:
            sys.stdout.write((e.output or b"").decode(errors="replace"))
            raise SystemExit(f"FAILED {where}: still running after {BLOCK_TIMEOUT_S} s")
        sys.stdout.write(done.stdout.decode(errors="replace"))
        print(f"    ({time.monotonic() - started:.1f} s, exit {done.returncode})", flush=True)
        if done.returncode != 0:
            raise SystemExit(f"FAILED {where}: exit {done.returncode}")

    def spawn(self, argv, log_name):
        log = open(os.path.join(self.dir, log_name), "w+")
        proc = subprocess.Popen(argv, cwd=self.cwd, env=self.env, stdout=log,
                                stderr=subprocess.STDOUT, start_new_session=True)
        self.servers.append(proc)
        return proc, log

    def wait_for(self, proc, log, pattern, where, what):
        deadline = time.monotonic() + SERVER_START_TIMEOUT_S
        while time.monotonic() < deadline:
            log.seek(0)
            text = log.read()
            m = re.search(pattern, text)
            if m:
                return m
            if proc.poll() is not None:
                raise SystemExit(f"FAILED {where}: {what} exited ({proc.returncode}):\n{text}")
            time.sleep(0.05)
        raise SystemExit(f"FAILED {where}: {what} did not start within {SERVER_START_TIMEOUT_S} s")

    def start_server(self, command, where):
        print(f"--- {where} (background)\n{command} --port 0", flush=True)
        proc, log = self.spawn(["bash", "-c", f"exec {command} --port 0"],
                               f".server{len(self.servers)}.log")
        m = self.wait_for(proc, log, r"listening on (\S+):(\d+)", where, command)
        host, port = m.group(1), m.group(2)
        if "tribo-bench" in command:
            self.point_modbus_configs_at(port)
        else:
            self.env["TRIBO_ADDRESS"] = f"{host}:{port}"
        print(f"    listening on {host}:{port}", flush=True)

    def point_modbus_configs_at(self, port):
        """The page's copy of every config whose Modbus link is TCP: this port."""
        for root, _, files in os.walk(os.path.join(self.dir, "config")):
            for name in files:
                if not name.endswith(".textproto"):
                    continue
                path = os.path.join(root, name)
                text = open(path).read()
                changed = re.sub(r"(tcp\s*\{[^}]*?\bport:\s*)\d+", r"\g<1>" + port, text)
                if changed != text:
                    open(path, "w").write(changed)

    def start_dask_cluster(self, where):
        scheduler_file = os.path.join(self.dir, ".dask-scheduler.json")
        proc, log = self.spawn(["dask-scheduler", "--host", "127.0.0.1", "--port", "0",
                                "--no-dashboard", "--scheduler-file", scheduler_file],
                               ".dask-scheduler.log")
        m = self.wait_for(proc, log, r"Scheduler at:\s+(tcp://\S+)", where, "dask-scheduler")
        address = m.group(1)
        proc, log = self.spawn(["dask-worker", address, "--nthreads", "1", "--nworkers", "1",
                                "--no-dashboard", "--host", "127.0.0.1"], ".dask-worker.log")
        self.wait_for(proc, log, r"Registered to:", where, "dask-worker")
        self.env["DASK_SCHEDULER"] = address
        print(f"--- {where}: a Dask scheduler and one worker at {address} in $DASK_SCHEDULER",
              flush=True)

    def close(self):
        for proc in reversed(self.servers):
            if proc.poll() is None:
                os.killpg(proc.pid, signal.SIGTERM)
        for proc in reversed(self.servers):
            try:
                proc.wait(timeout=20)
            except subprocess.TimeoutExpired:
                os.killpg(proc.pid, signal.SIGKILL)
                proc.wait()
        if self.keep:
            print(f"kept {self.dir}")
        else:
            shutil.rmtree(self.dir, ignore_errors=True)


def run_page(page, source_dir, build_dir, keep):
    blocks = runnable_blocks(page)
    if not blocks:
        return 0
    rel = os.path.relpath(page, source_dir)
    session = Page(rel, source_dir, build_dir, keep)
    started = time.monotonic()
    try:
        for block in blocks:
            session.run(*block)
    finally:
        session.close()
    print(f"=== {rel}: {len(blocks)} blocks in {time.monotonic() - started:.1f} s\n", flush=True)
    return len(blocks)


# ---------------------------------------------------------------- links

LINK = re.compile(r"!?\[(?:[^\]\[]|\[[^\]]*\])*\]\(([^)\s]+)(?:\s+\"[^\"]*\")?\)")
HEADING = re.compile(r"^(#{1,6})\s+(.*?)\s*#*\s*$")
TOP_DIRS = ("analysis", "bench", "client", "config", "daemon", "docs", "emulator", "hal",
            "proto", "scorecard", "scripts", "sim", "tests")
QUOTED_PATH = re.compile(r"`((?:%s)/[A-Za-z0-9_./-]+)`" % "|".join(TOP_DIRS))
BARE_PATH = re.compile(r"(?<![\w/.`-])((?:%s)/[A-Za-z0-9_/-]+\.(?:md|textproto|toml|py|cc|h|json|csv|png|sh|proto|ipynb))\b"
                       % "|".join(TOP_DIRS))


def tree_files(source_dir, suffixes):
    """The source tree's files whose names end in one of `suffixes`, build
    trees and hidden directories left out."""
    for root, dirs, files in os.walk(source_dir):
        dirs[:] = [d for d in dirs if not d.startswith(".") and d != "build"
                   and not d.startswith("build-") and d != "node_modules"]
        for name in files:
            if name.endswith(suffixes):
                yield os.path.join(root, name)


def markdown_files(source_dir):
    return tree_files(source_dir, (".md",))


def prose_lines(path):
    """(line number, text) outside fenced code blocks, inline code kept."""
    fence = None
    for n, line in enumerate(open(path, encoding="utf-8"), 1):
        m = FENCE.match(line.strip())
        if m:
            if fence is None:
                fence = m.group(1)
            elif line.strip().startswith(fence):
                fence = None
            continue
        if fence is None:
            yield n, line.rstrip("\n")


def slug(heading):
    text = re.sub(r"\[([^\]]*)\]\([^)]*\)", r"\1", heading)      # a link's text only
    text = text.lower().replace("`", "")
    text = re.sub(r"[^\w\- ]", "", text)
    return text.replace(" ", "-")


def anchors(path, cache={}):
    if path not in cache:
        seen, found = {}, set()
        for _, line in prose_lines(path):
            m = HEADING.match(line)
            if not m:
                continue
            base = slug(m.group(2))
            n = seen.get(base, 0)
            found.add(base if n == 0 else f"{base}-{n}")
            seen[base] = n + 1
        cache[path] = found
    return cache[path]


def check_links(source_dir):
    problems = []
    for path in sorted(markdown_files(source_dir)):
        rel = os.path.relpath(path, source_dir)
        here = os.path.dirname(path)
        for n, line in prose_lines(path):
            without_code = re.sub(r"`[^`]*`", "", line)
            for target in LINK.findall(without_code):
                if re.match(r"^[a-z]+:", target):
                    continue                                   # http:, https:, mailto:
                file_part, _, anchor = target.partition("#")
                dest = os.path.normpath(os.path.join(here, file_part)) if file_part else path
                if not os.path.exists(dest):
                    problems.append(f"{rel}:{n}: link to {target}: no such file")
                elif anchor and dest.endswith(".md") and anchor not in anchors(dest):
                    problems.append(f"{rel}:{n}: link to {target}: no heading #{anchor} in "
                                    f"{os.path.relpath(dest, source_dir)}")
            quoted = QUOTED_PATH.findall(line) + BARE_PATH.findall(without_code)
            for repo_path in quoted:
                repo_path = repo_path.rstrip(".")
                if any(re.fullmatch(r"[A-Z][A-Z_]+", part.split(".")[0])
                       for part in repo_path.split("/")):
                    continue                                   # a placeholder: NAME.textproto
                if not os.path.exists(os.path.join(source_dir, repo_path)):
                    problems.append(f"{rel}:{n}: names {repo_path}: no such file")
    return problems


# A section named by its page, in the docs or in a comment: `page.md, "Heading"`,
# `(page.md) ("Heading")`, `page.md's "Heading"`, `page.md "A" and "B"`.
SECTION_REF = re.compile(r'((?:[\w.-]+/)*[\w.-]+\.md)\)?(?:\'s)?,?\s*\(?"([^"\n]{3,100})"(?:\s+and\s+"([^"\n]{3,100})")?')
PARAGRAPH_LABEL = re.compile(r"^\*\*([^*]+?)\*\*")
TEXT_SUFFIXES = (".md", ".cc", ".h", ".py", ".textproto", ".toml", ".proto", ".sh", ".txt", ".cmake")


def section_key(title):
    """A section title compared without case, markup or a closing stop."""
    return re.sub(r"[`*_]", "", title).strip().rstrip(".:").strip().lower()


def section_names(path, cache={}):
    """A page's headings and paragraph labels (`**Label.**` opening a line);
    a heading also by its text before a closing parenthesis ("Cost (measured
    ...)" answers to "Cost")."""
    if path not in cache:
        names = set()
        for _, line in prose_lines(path):
            m = HEADING.match(line)
            if m:
                names.add(section_key(m.group(2)))
                names.add(section_key(re.sub(r"\s*\([^()]*\)$", "", m.group(2))))
            m = PARAGRAPH_LABEL.match(line)
            if m:
                names.add(section_key(m.group(1)))
        cache[path] = names
    return cache[path]


def check_section_names(source_dir):
    """Each section a file names by its page and quoted title is a heading or
    a paragraph label of that page (a page is looked for beside the file, at
    the top of the tree, then in docs/)."""
    problems = []
    for path in sorted(tree_files(source_dir, TEXT_SUFFIXES)):
        rel = os.path.relpath(path, source_dir)
        try:
            lines = open(path, encoding="utf-8").read().splitlines()
        except UnicodeDecodeError:
            continue
        for n, line in enumerate(lines, 1):
            for m in SECTION_REF.finditer(line):
                page = m.group(1)
                places = [os.path.join(os.path.dirname(path), page), os.path.join(source_dir, page),
                          os.path.join(source_dir, "docs", os.path.basename(page))]
                target = next((os.path.normpath(p) for p in places if os.path.isfile(p)), None)
                if target is None:
                    continue                                   # another project's page
                names = section_names(target)
                for title in filter(None, (m.group(2), m.group(3))):
                    if section_key(title) not in names:
                        problems.append(f'{rel}:{n}: names section "{title}": no such heading in '
                                        f"{os.path.relpath(target, source_dir)}")
    return problems


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--build-dir", required=True)
    parser.add_argument("--source-dir", required=True)
    parser.add_argument("--keep", action="store_true", help="keep the scratch directories")
    parser.add_argument("--links-only", action="store_true", help="only check the links")
    parser.add_argument("--no-links", action="store_true", help="only run the pages' blocks")
    parser.add_argument("pages", nargs="*", help="pages to run (default: every page with a marker)")
    args = parser.parse_args()
    source_dir = os.path.realpath(args.source_dir)
    build_dir = os.path.realpath(args.build_dir)

    problems = [] if args.no_links else check_links(source_dir) + check_section_names(source_dir)
    for p in problems:
        print(p)
    if problems:
        print(f"FAILED: {len(problems)} broken links, paths or section names in the docs")
        return 1
    if not args.no_links:
        print("links: every link, quoted path and named section of the docs resolves")
    if args.links_only:
        return 0

    pages = [os.path.realpath(p) for p in args.pages] or sorted(markdown_files(source_dir))
    started, blocks = time.monotonic(), 0
    for page in pages:
        blocks += run_page(page, source_dir, build_dir, args.keep)
    if blocks == 0:
        print("FAILED: no runnable block found")
        return 1
    print(f"{blocks} doc blocks ran in {time.monotonic() - started:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
