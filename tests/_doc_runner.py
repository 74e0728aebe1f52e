"""Run one page's code blocks in order, as a reader would: `python _doc_runner.py BLOCKS.json`.

BLOCKS.json is `tests._doc_pages.script(page)`. Python blocks share one namespace; shell
blocks run with `bash -e -o pipefail`. Stops at the first block that fails, naming it
("DOCS BLOCK FAILED: page:line") on stderr, and exits 1.
"""

import json
import subprocess
import sys
import traceback


def main(path: str) -> int:
    with open(path, encoding="utf-8") as f:
        todo = json.load(f)
    namespace = {"__name__": "__main__"}
    for block in todo:
        where = block["where"]
        print(f"--- {where} ({block['lang']})", flush=True)
        if block["lang"] == "python":
            try:
                exec(compile(block["code"], where, "exec"), namespace)
            except BaseException:
                traceback.print_exc()
                print(f"DOCS BLOCK FAILED: {where}", file=sys.stderr, flush=True)
                return 1
            sys.stdout.flush()
            continue
        proc = subprocess.run(["bash", "-e", "-o", "pipefail", "-c", block["code"]], check=False)
        if proc.returncode != block["exit"]:
            print(
                f"DOCS BLOCK FAILED: {where}: exit {proc.returncode}, expected {block['exit']}",
                file=sys.stderr,
                flush=True,
            )
            return 1
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1]))
