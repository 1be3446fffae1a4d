"""MkDocs hook: links to repository files outside docs/, and the changelog page.

The pages are also read on the repository's web view, where a link such as
``../../benchmarks/README.md`` works; the site holds only docs/, so such a link would dangle
there. Each relative link whose target lies outside docs/ and exists in the repository
becomes, in the site, a link to the repository's web view when mkdocs.yml sets ``repo_url``,
and otherwise the link's text followed by the file's repository path. A target that exists
nowhere is left alone, so ``mkdocs build --strict`` still fails on it.

``changelog.md`` is made from the repository's ``CHANGELOG.md`` with its links rebased from
the repository root onto docs/.
"""

from __future__ import annotations

import os
import re
from pathlib import Path
from typing import Any

CHANGELOG = "CHANGELOG.md"
CHANGELOG_PAGE = "changelog.md"
#: an inline link or image: [text](target "title") -- text without nested brackets
INLINE = re.compile(
    r"(?P<bang>!?)\[(?P<text>[^\]\[]*)\]\((?P<target>[^)\s]+)(?P<title>\s+\"[^\"]*\")?\)"
)
#: a reference definition: [label]: target
DEFINITION = re.compile(r"^(?P<head>\s{0,3}\[[^\]]+\]:\s*)(?P<target>\S+)(?P<tail>.*)$")
FENCE = re.compile(r"^\s*(```|~~~)")


def _is_relative(target: str) -> bool:
    has_scheme = re.match(r"^[a-z][a-z0-9+.-]*:", target) is not None
    return not (target.startswith(("#", "/")) or has_scheme)


class LinkRebaser:
    """Rewrites the relative links of one Markdown text for its place in the site.

    Args:
        repo_root: the repository's root folder.
        docs_dir: the site's source folder (inside ``repo_root``).
        written_in: the folder the text's links are relative to.
        page_dir: the folder of the page inside ``docs_dir``.
        repo_url: the repository's web address, or None.
    """

    def __init__(
        self, repo_root: Path, docs_dir: Path, written_in: Path, page_dir: Path,
        repo_url: str | None,
    ) -> None:
        self.repo_root = repo_root.resolve()
        self.docs_dir = docs_dir.resolve()
        self.written_in = written_in.resolve()
        self.page_dir = page_dir.resolve()
        self.repo_url = repo_url.rstrip("/") if repo_url else None

    def target(self, target: str) -> tuple[str, str | None]:
        """The target in the site and, for a repository file outside docs/, its path."""
        path, _, anchor = target.partition("#")
        if not path or not _is_relative(target):
            return target, None
        resolved = Path(os.path.normpath(self.written_in / path))
        if resolved.is_relative_to(self.docs_dir):
            rebased = os.path.relpath(resolved, self.page_dir).replace(os.sep, "/")
            return rebased + (f"#{anchor}" if anchor else ""), None
        if not resolved.is_relative_to(self.repo_root) or not resolved.exists():
            return target, None  # left for the strict build to report
        in_repo = resolved.relative_to(self.repo_root).as_posix()
        if self.repo_url:
            kind = "tree" if resolved.is_dir() else "blob"
            url = f"{self.repo_url}/{kind}/HEAD/{in_repo}"
            return url + (f"#{anchor}" if anchor else ""), in_repo
        return "", in_repo

    def inline(self, match: re.Match[str]) -> str:
        """One inline link or image, rewritten."""
        site_target, in_repo = self.target(match["target"])
        if in_repo is None or site_target:
            title = match["title"] or ""
            return f"{match['bang']}[{match['text']}]({site_target}{title})"
        text = match["text"]
        return text if in_repo in text else f"{text} (`{in_repo}`)"

    def definition(self, match: re.Match[str]) -> str:
        """One reference definition, rewritten (a repository path without repo_url: as text)."""
        site_target, in_repo = self.target(match["target"])
        return f"{match['head']}{site_target or in_repo}{match['tail']}"

    def rewrite(self, markdown: str) -> str:
        """The Markdown with every relative link outside code blocks rewritten."""
        lines, fenced = [], False
        for line in markdown.split("\n"):
            if FENCE.match(line):
                fenced = not fenced
            elif not fenced:
                line = DEFINITION.sub(self.definition, line)
                line = INLINE.sub(self.inline, line)
            lines.append(line)
        return "\n".join(lines)


def _roots(config: Any) -> tuple[Path, Path]:
    return Path(config.config_file_path).parent, Path(config.docs_dir)


def on_files(files: Any, config: Any) -> Any:
    """Add ``changelog.md``, made from the repository's CHANGELOG.md."""
    from mkdocs.exceptions import PluginError
    from mkdocs.structure.files import File

    repo_root, docs_dir = _roots(config)
    source = repo_root / CHANGELOG
    if not source.is_file():
        raise PluginError(f"{source} not found: the site's changelog page is made from it")
    rebaser = LinkRebaser(repo_root, docs_dir, repo_root, docs_dir, config.repo_url)
    content = rebaser.rewrite(source.read_text(encoding="utf-8"))
    files.append(File.generated(config, CHANGELOG_PAGE, content=content))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """Rewrite a page's links to repository files outside docs/."""
    if page.file.generated_by is not None:
        return markdown  # generated pages are written for the site already
    repo_root, docs_dir = _roots(config)
    page_dir = (docs_dir / page.file.src_uri).parent
    return LinkRebaser(repo_root, docs_dir, page_dir, page_dir, config.repo_url).rewrite(markdown)
