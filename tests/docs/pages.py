"""What the docs-page tests share: a page's `bearingdyn` commands, as a user would type them."""

from __future__ import annotations

import re
import shlex


def page_commands(text: str) -> list[list[str]]:
    """The ``bearingdyn`` commands of the page's bash blocks, continuation lines joined."""
    out = []
    for block in re.findall(r"```bash\n(.*?)```", text, flags=re.S):
        for line in block.replace("\\\n", " ").splitlines():
            if line.strip().startswith("bearingdyn "):
                out.append(shlex.split(line.split("#")[0])[1:])
    return out
