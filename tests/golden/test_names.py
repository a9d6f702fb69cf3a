#!/usr/bin/env python3
"""The test functions of the repository at a git revision, one name per line, sorted:
every `#[test]` function and every function of a `proptest!` block in the `.rs` files of
the revision. A refactoring loses no test when `comm -23` of the lists before and after
is empty:

    comm -23 <(python3 tests/golden/test_names.py OLD) <(python3 tests/golden/test_names.py HEAD)
"""
import re, subprocess, sys
rev = sys.argv[1] if len(sys.argv) > 1 else "HEAD"
repo = sys.argv[2] if len(sys.argv) > 2 else "."
files = subprocess.run(["git", "-C", repo, "ls-tree", "-r", "--name-only", rev], capture_output=True, text=True).stdout.split()
names = set()
for f in files:
    if not f.endswith(".rs"):
        continue
    src = subprocess.run(["git", "-C", repo, "show", f"{rev}:{f}"], capture_output=True, text=True).stdout
    # #[test] (possibly with other attrs) followed by fn name
    for m in re.finditer(r"#\[(?:tokio::)?test[^\]]*\](?:\s*#\[[^\]]*\])*\s*(?:async\s+)?fn\s+([a-zA-Z0-9_]+)", src):
        names.add(m.group(1))
    # proptest! blocks: fns inside
    for blk in re.finditer(r"proptest!\s*\{", src):
        depth = 0; i = blk.end() - 1
        start = i
        while i < len(src):
            if src[i] == "{": depth += 1
            elif src[i] == "}":
                depth -= 1
                if depth == 0: break
            i += 1
        for m in re.finditer(r"\bfn\s+([a-zA-Z0-9_]+)", src[start:i]):
            names.add(m.group(1))
for n in sorted(names):
    print(n)
