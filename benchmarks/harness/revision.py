"""Another git revision of the package, importable beside this tree's.

``python benchmarks/against.py`` and ``python benchmarks/stages.py --against``
time a revision's forms in the same process as this tree's, so that the load
of a shared machine falls on both alike.
"""

from __future__ import annotations

import functools
import glob
import os
import re
import subprocess
import sys
import tempfile


@functools.cache
def extracted(revision: str):
    """The package at git ``revision``, imported as ``jaxcontact_against``
    (extracted with ``git archive``, every ``jaxcontact`` renamed in its source)."""
    folder = tempfile.mkdtemp(prefix="jaxcontact-against-")
    archive = subprocess.run(
        ["git", "archive", revision, "jaxcontact"], check=True, capture_output=True
    ).stdout
    subprocess.run(["tar", "-x", "-C", folder], input=archive, check=True)
    os.rename(os.path.join(folder, "jaxcontact"), os.path.join(folder, "jaxcontact_against"))
    for path in glob.glob(os.path.join(folder, "jaxcontact_against", "**", "*.py"), recursive=True):
        with open(path) as stream:
            text = re.sub(r"\bjaxcontact\b", "jaxcontact_against", stream.read())
        with open(path, "w") as stream:
            stream.write(text)
    sys.path.insert(0, folder)
    import jaxcontact_against

    return jaxcontact_against
