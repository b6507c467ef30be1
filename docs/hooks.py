"""MkDocs hooks of the docs site (``mkdocs.yml``): tables generated from the code, and the
repository's ``assets/`` images the pages show.

* A page line ``<!-- generated: config ENV_ID -->`` becomes the table of the scenario's config
  fields (name, default, meaning), read from its frozen dataclass and the ``Attributes:`` section
  of its docstring; ``observation ENV_ID`` the observation layout, ``actions ENV_ID`` the action
  space, ``infos ENV_ID`` the info keys (``box2d_driving.envs.core.INFO_FIELDS``), ``reward`` the
  reward terms (from ``box2d_driving/envs/reward.py``) and ``modules
  PACKAGE`` one line per module of ``box2d_driving``, ``training`` or ``tests`` (the first
  sentence of its docstring). So the pages cannot drift from the code.
* Pages link the shipped policies' plots as ``../assets/...`` (which also works when the
  Markdown is read on its own); the site copies those files in and points the links at them.
"""

from __future__ import annotations

import dataclasses
import inspect
import posixpath
import re
from pathlib import Path

from mkdocs.structure.files import File

ROOT = Path(__file__).resolve().parent.parent
SHOWN_ASSETS = ("*.png", "*.gif")
GENERATED = re.compile(r"^<!-- generated: (\w+)(?: ([\w-]+))? -->$", re.M)
LINK = re.compile(r"(\]\()([^)#\s]+)")


def on_files(files, config):
    """Add the images under the repository's ``assets/`` as site files ``assets/...``."""
    for pattern in SHOWN_ASSETS:
        for path in sorted((ROOT / "assets").rglob(pattern)):
            uri = path.relative_to(ROOT).as_posix()
            files.append(File(uri, str(ROOT), config["site_dir"], config["use_directory_urls"]))
    return files


def on_page_markdown(markdown, page, config, files):
    markdown = GENERATED.sub(lambda m: _generated(m.group(1), m.group(2)), markdown)
    return LINK.sub(lambda m: m.group(1) + _site_link(page.file.src_uri, m.group(2)), markdown)


def _site_link(page_uri: str, target: str) -> str:
    """A link to ``../assets/...`` (outside the docs folder) as a link to the copied file."""
    if "://" in target:
        return target
    here = posixpath.dirname(page_uri)
    resolved = posixpath.normpath(posixpath.join("docs", here, target))  # from the repository root
    if not resolved.startswith("assets/"):
        return target
    return posixpath.relpath(resolved, here or ".")  # the copy sits at the same path in the site


def _generated(kind: str, target: str | None) -> str:
    """The generated text of a ``<!-- generated: KIND TARGET -->`` line; TARGET is an env id, or
    for ``modules`` a package folder."""
    import box2d_driving

    if kind == "reward":
        return _reward_table()
    if kind == "modules":
        return _module_table(target)
    env = box2d_driving.make(target)
    try:
        return {"config": _config_table, "observation": _observation_table, "actions": _actions_text,
                "infos": _infos_table}[kind](env, target)
    finally:
        env.close()


def _attributes(cls) -> dict[str, str]:
    """Field descriptions from the ``Attributes:`` sections of ``cls`` and its bases (a line
    ``a, b: text`` describes both)."""
    out: dict[str, str] = {}
    for klass in reversed(cls.__mro__):
        doc = inspect.getdoc(klass) or ""
        if "Attributes:" not in doc:
            continue
        name = None
        for line in doc.split("Attributes:", 1)[1].splitlines():
            m = re.match(r"^    (\w[\w, ]*):\s*(.*)$", line)
            if line.startswith("        ") and name:  # a description's continuation line
                for n in name:
                    out[n] += " " + line.strip()
            elif m:
                name = [n.strip() for n in m.group(1).split(",")]
                for n in name:
                    out[n] = m.group(2).strip()
            elif line.strip() and not line.startswith(" "):
                break
    return out


def _cell(text: str) -> str:
    return text.replace("|", "\\|").replace("\n", " ")


def _config_table(env, env_id: str) -> str:
    cls = type(env.config)
    about = _attributes(cls)
    rows = ["| field | default | meaning |", "|---|---|---|"]
    for f in dataclasses.fields(cls):
        default = getattr(env.config, f.name)
        rows.append(f"| `{f.name}` | `{_cell(repr(default))}` | {_cell(about.get(f.name, ''))} |")
    return (f"Every field of `{cls.__name__}` (`{cls.__module__}`), with its default; pass any of them "
            f"to `box2d_driving.make(\"{env_id}\", FIELD=VALUE)` or `--set FIELD=VALUE`.\n\n"
            + "\n".join(rows))


def _observation_table(env, env_id: str) -> str:
    lay = env.observation_layout
    cfg = env.config
    encoding = ("1 / distance, 0 where nothing is in range or the ray was dropped"
                if cfg.lidar_encoding == "inverse" else "1 - distance / range, 0 where nothing is in range")
    rows = ["| part | size | what |", "|---|---:|---|",
            f"| LiDAR | {lay.history} x {lay.n_rays} | the last {lay.history} frames (oldest first) of "
            f"{lay.n_rays} rays over 360 degrees from the heading, range {cfg.lidar_range:g} m: {encoding} |",
            f"| sat-nav | {lay.history} x {lay.n_satnav} | per frame: "
            + ", ".join(f"`{f}`" for f in lay.satnav_fields) + " |"]
    return (f"One flat `float32` vector of {lay.size} values per car "
            f"(`env.observation_layout` gives the slices):\n\n" + "\n".join(rows))


def _actions_text(env, env_id: str) -> str:
    cfg = env.config
    levels = ", ".join(f"{a:g}" for a in cfg.accelerations)
    text = (f"`Discrete({cfg.n_actions})`: action `k` holds acceleration level `k` of ({levels}) m/s², "
            f"scaled by the car's rating, for one decision ({cfg.substeps} physics steps of {cfg.dt:g} s).")
    if cfg.communication:
        text += f" With `communication=True`, action `k + {len(cfg.accelerations)} * bit` also sends the bit."
    space = getattr(env, "spline_action_space", None)
    if space is not None:
        text += (f" Before the episode each car also picks its path: one stage-0 action from "
                 f"`env.spline_action_space` = `{space}` for its stage-0 observation "
                 f"(`env.spline_observation_space`).")
    return text


def _infos_table(env, env_id: str) -> str:
    from box2d_driving.envs.core import INFO_FIELDS

    _, infos = env.reset(seed=0)
    keys = list(next(iter(infos.values())))
    meaning = {**INFO_FIELDS, **env.scenario_info_fields}
    rows = ["| key | meaning |", "|---|---|"]
    rows += [f"| `{k}` | {_cell(meaning[k])} |" for k in keys + ["reward_terms"]]
    return ("`infos[agent]` after `reset` and each `step`, for the cars still in the episode (a car's "
            "last `step` reports it once more, with `arrived` or `collided` set; collect outcomes then):\n\n"
            + "\n".join(rows))


def _reward_table() -> str:
    from box2d_driving.envs import reward

    doc = inspect.getdoc(reward) or ""
    terms = doc.split("\n\n", 1)[1]
    return (terms + f"\n\nEach decision's reward is the sum of the terms {', '.join(f'`{t}`' for t in reward.TERMS)}; "
            "`infos[agent][\"reward_terms\"]` holds them one by one.")


def module_summaries(package: str) -> dict[str, str]:
    """Each module file of ``package`` (a folder at the repository root; ``__main__`` left out)
    -> the first sentence of its docstring, read without importing it ("" where it has none)."""
    import ast

    out = {}
    for path in sorted((ROOT / package).rglob("*.py")):
        if path.name == "__main__.py":
            continue
        doc = ast.get_docstring(ast.parse(path.read_text(encoding="utf-8"))) or ""
        first = " ".join(doc.split("\n\n", 1)[0].split())
        sentence = re.split(r"(?<=\.)\s(?=[A-Z`(])", first, maxsplit=1)[0] if first else ""
        out[path.relative_to(ROOT / package).as_posix()] = sentence
    return out


def _module_table(package: str) -> str:
    rows = ["| module | what it is |", "|---|---|"]
    for module, sentence in module_summaries(package).items():
        shown = SPHINX_ROLE.sub(r"`\1`", sentence).replace("``", "`")
        rows.append(f"| `{module}` | {_cell(shown)} |")
    return (f"Every module of `{package}`, by the first sentence of its docstring (generated when the "
            "site is built):\n\n" + "\n".join(rows))


# -- a Griffe extension (``mkdocs.yml``: mkdocstrings' ``extensions``) --------------------------
SPHINX_ROLE = re.compile(r":(?:mod|class|func|meth|attr|data|exc|obj):`~?([^`]+)`")

try:
    import griffe
except ImportError:  # only the API reference needs it; the hooks above do not
    griffe = None

if griffe is not None:
    class SphinxRoles(griffe.Extension):
        """The docstrings name code the Sphinx way (``:class:`Name```); the API reference shows
        those names as code, as the plain Markdown around them does."""

        def on_object(self, *, obj, **kwargs) -> None:
            if obj.docstring is not None:
                obj.docstring.value = SPHINX_ROLE.sub(r"`\1`", obj.docstring.value)
