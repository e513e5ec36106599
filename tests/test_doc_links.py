"""Every file, section and path the documents name exists in the repository.

Checked: README.md, CHANGELOG.md, results_schema.md, every page of docs/, the campaign notes
and logs under campaigns/, configs/README.md and the comments of
configs/*.yaml, workflows/README.md.  The documentation site (docs/conf.py) is checked too:
every page is in its table of contents, and every file it includes or maps a link to exists.

A reference is a markdown link (``[text](target)``, with an optional ``#anchor``), a
repository path (``docs/x.md``, ``configs/y.yaml``, ``fcsweep/.../z.py``, ...), a bare ``NAME.md``,
or a README section quoted as
``README "Title"`` / ``README: "Title"``.  Files a sweep writes (``trajectory.h5``,
``phase_diagram.nc``, ...) are names, not references, and are not checked.
"""

from __future__ import annotations

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
SITE = ROOT / "docs"
DOCS = sorted({*ROOT.glob("*.md"), *(ROOT / "docs").rglob("*.md"), *(ROOT / "campaigns").rglob("*.md"),
               ROOT / "configs" / "README.md",
               *(ROOT / "configs").glob("*.yaml"), ROOT / "workflows" / "README.md"})

LINK = re.compile(r"\[[^\]]*\]\(([^)\s]+)\)")
PATH = re.compile(r"(?<![\w./-])((?:docs|configs|fcsweep|tests|benchmarks|workflows|campaigns)/[\w./-]*\w)(?![\w*<{])")
BARE_MD = re.compile(r"(?<![\w./-])([A-Za-z][\w-]*\.md)\b")
SECTION = re.compile(r"README:?\s*[\"“]([^\"”]+)[\"”]")


def _slug(title: str) -> str:
    """GitHub's anchor of a heading."""
    s = re.sub(r"[^\w\- ]", "", title.strip().lower())
    return s.replace(" ", "-")


def _headings(path: Path) -> list[str]:
    return [m.group(1).strip() for m in re.finditer(r"^#+\s+(.*)$", path.read_text(), re.M)]


#: What a documented command builds (git-ignored): named before it exists.
BUILT = ("docs/_build/",)


def _exists(target: str, doc: Path) -> bool:
    target = target.rstrip(".,;:")
    if (target + "/").startswith(BUILT):
        return True
    return (doc.parent / target).exists() or (ROOT / target).exists()


def _references(doc: Path):
    text = doc.read_text()
    if doc.suffix == ".yaml":  # only comments document anything in a config
        text = "\n".join(line.split("#", 1)[1] for line in text.splitlines() if "#" in line)
    for m in LINK.finditer(text):
        yield "link", m.group(1)
    for m in PATH.finditer(text):
        yield "path", m.group(1)
    for m in BARE_MD.finditer(text):
        yield "md", m.group(1)
    for m in SECTION.finditer(text):
        yield "section", m.group(1)


@pytest.mark.parametrize("doc", DOCS, ids=lambda p: str(p.relative_to(ROOT)))
def test_every_reference_resolves(doc):
    readme_titles = _headings(ROOT / "README.md")
    broken = []
    for kind, ref in _references(doc):
        if kind == "link":
            if re.match(r"[a-z]+://|mailto:", ref):
                continue
            target, _, anchor = ref.partition("#")
            dest = doc if not target else doc.parent / target
            if target and not dest.exists():
                broken.append(f"link {ref}")
            elif anchor and dest.suffix == ".md" and anchor not in {_slug(h) for h in _headings(dest)}:
                broken.append(f"anchor {ref}")
        elif kind == "path" and not _exists(ref, doc):
            broken.append(f"path {ref}")
        elif kind == "md":
            if not (_exists(ref, doc) or (ROOT / "docs" / ref).exists() and doc.parent.name == "docs"):
                broken.append(f"file {ref}")
        elif kind == "section" and ref not in readme_titles:
            broken.append(f'README section "{ref}"')
    assert not broken, f"{doc.relative_to(ROOT)}: unresolved " + "; ".join(sorted(set(broken)))


def test_the_checker_sees_broken_references(tmp_path):
    """The patterns catch the kinds of breakage the documents had."""
    doc = tmp_path / "x.md"
    doc.write_text('See MODEL.md and [a](nowhere.md), docs/nothing.md, README "No such section".')
    kinds = {k for k, _ in _references(doc)}
    assert kinds == {"link", "path", "md", "section"}


# ------------------------------------------------------------------ the documentation site

INCLUDE = re.compile(r"^```\{include\}\s+(\S+)\s*$", re.M)
TOCTREE = re.compile(r"^```\{toctree\}\n(.*?)^```", re.M | re.S)


def _site_conf():
    """docs/conf.py as a module (it only adds the repository to sys.path and imports fcsweep)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("fcsweep_docs_conf", SITE / "conf.py")
    conf = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(conf)
    return conf


def _excluded(page: Path, patterns) -> bool:
    rel = page.relative_to(SITE)
    return any(rel.match(p) or rel.as_posix().startswith(p.rstrip("*/") + "/") for p in patterns)


def _toctree_entries() -> set[str]:
    entries = set()
    for page in SITE.rglob("*.md"):
        for block in TOCTREE.findall(page.read_text()):
            entries |= {ln.strip() for ln in block.splitlines() if ln.strip() and not ln.startswith(":")}
    return entries


def test_every_page_is_in_the_site():
    """A page added to docs/ shows up in the site's tables of contents (or is excluded on
    purpose in docs/conf.py), and every entry of them is a page."""
    conf = _site_conf()
    pages = {p.relative_to(SITE).with_suffix("").as_posix() for p in [*SITE.rglob("*.md"), *SITE.rglob("*.ipynb")]
             if not _excluded(p, conf.exclude_patterns)}
    entries = _toctree_entries()
    assert pages - {"index"} <= entries, f"pages in no toctree of docs/index.md: {sorted(pages - entries - {'index'})}"
    assert entries <= pages, f"toctree entries that are not pages: {sorted(entries - pages)}"


def test_the_site_includes_and_maps_files_that_exist():
    """The pages that include a repository file (configuration, schema, clusters, ...)
    include one that exists, and the links the site redirects to a page point at files
    that exist and at pages of the site."""
    included = {}
    for page in SITE.rglob("*.md"):
        for target in INCLUDE.findall(page.read_text()):
            included[target] = (page.parent / target).resolve()
    for must in ("configs/README.md", "results_schema.md", "workflows/README.md", "CHANGELOG.md"):
        assert ROOT / must in included.values(), f"no page of docs/ includes {must}"
    missing = [t for t, path in included.items() if not path.exists()]
    assert not missing, f"included files missing: {missing}"
    for target, page in _site_conf().PAGE_OF.items():
        assert (SITE / target).exists(), f"docs/conf.py PAGE_OF: {target} does not exist"
        assert (SITE / page).exists() and (SITE / target).resolve() in included.values(), \
            f"docs/conf.py PAGE_OF: {page} should be the page that includes {target}"
