"""User-facing text (docstrings, docs, READMEs) points only at what a user has: the project's own docs."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from tests.helpers import HANG

ROOT = Path(__file__).resolve().parents[1]


def _user_facing() -> list[Path]:
    files = [ROOT / "README.md", *sorted((ROOT / "docs").rglob("*.md")), *sorted((ROOT / "assets").rglob("README.md"))]
    return files + sorted((ROOT / "box2d_driving").rglob("*.py")) + sorted((ROOT / "training").rglob("*.py"))


def test_no_text_cites_the_internal_design_spec():
    # users get the package, not the design notes it was built from; "SPEC 6.4" means nothing to them
    cited = [f"{p.relative_to(ROOT)}:{n}" for p in _user_facing()
             for n, line in enumerate(p.read_text(encoding="utf-8").splitlines(), 1) if re.search(r"\bSPEC\b", line)]
    assert not cited, f"cites SPEC: {cited}"


def test_every_docs_page_named_in_code_or_docs_exists():
    named = set()
    for p in _user_facing():
        text = p.read_text(encoding="utf-8")
        named |= {m for m in re.findall(r"\bdocs/([\w-]+\.md)", text)}
        if p.parent.name == "docs":  # relative links between the docs pages
            named |= {m for m in re.findall(r"\]\(([\w-]+\.md)(?:#[\w-]*)?\)", text)}
    missing = sorted(n for n in named if not (ROOT / "docs" / n).exists())
    assert named and not missing, f"named but absent under docs/: {missing}"


def test_the_readmes_links_into_the_docs_land_on_a_heading():
    """The docs site checks its own anchors (strict build); the README's links into docs/ pages are
    checked here, by the heading anchors GitHub makes (lower case, punctuation dropped)."""
    from training.results.markdown import anchor

    links = re.findall(r"\]\((docs/[\w/-]+\.md)#([\w-]+)\)", (ROOT / "README.md").read_text(encoding="utf-8"))
    assert links
    broken = []
    for page, target in links:
        headings = re.findall(r"^#+ (.+)$", (ROOT / page).read_text(encoding="utf-8"), flags=re.M)
        if target not in {anchor(h.strip()) for h in headings}:
            broken.append(f"{page}#{target}")
    assert not broken, f"README links to no heading: {broken}"


@pytest.fixture(scope="module")
def built_site(tmp_path_factory):
    """The docs site built in strict mode: warnings (a broken internal link or anchor, a page left
    out of the navigation, an API reference that does not resolve) fail the build."""
    pytest.importorskip("mkdocs")
    pytest.importorskip("mkdocstrings")
    site = tmp_path_factory.mktemp("docs") / "site"
    out = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "--site-dir", str(site)],
                         cwd=ROOT, capture_output=True, text=True, timeout=HANG)
    assert out.returncode == 0, out.stderr[-3000:]
    return site


def test_the_docs_site_builds_in_strict_mode(built_site):
    page = (built_site / "scenarios" / "intersection" / "index.html").read_text(encoding="utf-8")
    # the settings table is generated from the config dataclass: its fields and their meanings
    assert "<code>lidar_noise</code>" in page and "share of rays dropped" in page
    assert (built_site / "reference" / "envs" / "index.html").exists()


@pytest.mark.e2e  # a browser per page: about a minute, in CI's second step
def test_every_page_of_the_site_loads_in_a_browser_without_errors(built_site):
    """The built site as a person sees it: every page opened in headless Chromium from a local
    server, with no console error, no request the server answers with an error (a missing image,
    script or style) and no link to a file of the site that is not there."""
    from tests.browser import CHROMIUM, browse_site

    if CHROMIUM is None:
        pytest.skip("no Chromium here (.ci/run installs it with apt-get where the machine allows)")
    report = browse_site(built_site)
    assert report.pages >= 30, report
    assert not report.console_errors, "\n".join(report.console_errors[:20])
    assert not report.failed_requests, report.failed_requests[:20]
    assert not report.broken_links, report.broken_links[:20]


def test_the_browser_check_sees_a_script_error_a_missing_image_and_a_dead_link(tmp_path):
    from tests.browser import CHROMIUM, browse_site

    if CHROMIUM is None:
        pytest.skip("no Chromium here (.ci/run installs it with apt-get where the machine allows)")
    (tmp_path / "ok").mkdir()
    (tmp_path / "ok" / "index.html").write_text("<html><body>fine</body></html>")
    (tmp_path / "favicon.ico").write_bytes(b"")  # asked for by the browser itself
    (tmp_path / "index.html").write_text('<html><body>'
                                         '<img src="missing.png"><a href="ok/">ok</a><a href="gone/">gone</a>'
                                         "<script>notDefinedAnywhere();</script></body></html>")
    report = browse_site(tmp_path)
    assert report.pages == 2
    assert len(report.console_errors) == 1 and "notDefinedAnywhere" in report.console_errors[0]
    assert report.failed_requests == ["404 /missing.png"]
    assert sorted(link.split(": ")[1] for link in report.broken_links) == ["gone/", "missing.png"]


def test_the_own_scenario_tutorial_runs_as_written(tmp_path, monkeypatch, capsys):
    from box2d_driving import scenarios

    _, blocks = _tutorial("own-scenario.md")
    assert len(blocks) == 3
    monkeypatch.chdir(tmp_path)  # the tutorial's runs/crossing lands here
    monkeypatch.setattr(scenarios, "_REGISTERED", dict(scenarios._REGISTERED))  # crossing-v0 for this test only
    namespace: dict = {}
    for block in blocks:  # the scenario, PettingZoo's API test on it, then registered, trained, measured
        exec(compile(block, "own-scenario.md", "exec"), namespace)
    env = namespace["CrossingEnv"](num_cars=4)
    assert env.observation_layout.satnav_fields[-1] == "crossing_busy"
    measured = eval(capsys.readouterr().out.strip().splitlines()[-1])  # the last print: measure's dict
    assert set(measured) == {"success_rate", "collision_rate", "shared_crossing_share"}
    assert all(0.0 <= v <= 1.0 for v in measured.values())
    assert (tmp_path / "runs" / "crossing" / "model.safetensors").is_file()
    table = namespace["table"]
    assert set(np.unique(table["crossing_busy"][table["decision"] > 0])) <= {0.0, 1.0}


# Sizes a test may shrink a tutorial's command to (smaller, never different): the tiny training
# settings of tests/test_training.py, two evaluation episodes, one small rendered episode.
_SMALLER = {"train": ["--timesteps", "160", "--n-envs", "2", "--batch-decisions", "80", "--num-cars", "2",
                      "--threads", "1", "--epochs", "1"],
            "evaluate": ["--episodes", "2"],
            "render": ["--episodes", "1", "--set", "render_size=(96, 96)"]}


def _examples(text: str) -> tuple[list[str], list[str]]:
    """A page's ``box2d-driving`` command lines in its code blocks (continuation lines joined,
    trailing comments dropped), and its Python blocks."""
    lines = [line.split(" # ")[0].strip() for block in re.findall(r"```[a-z]*\n(.*?)```", text, re.S)
             for line in block.replace("\\\n", " ").splitlines()]
    return [line for line in lines if line.startswith("box2d-driving ")], re.findall(r"```python\n(.*?)```", text, re.S)


def _commands_and_blocks(page: Path) -> tuple[list[list[str]], list[str]]:
    """A page's command lines as argv lists without the program name, and its Python blocks."""
    import shlex

    lines, blocks = _examples(page.read_text())
    return [shlex.split(line)[1:] for line in lines], blocks


def _tutorial(name: str) -> tuple[list[list[str]], list[str]]:
    return _commands_and_blocks(ROOT / "docs" / "tutorials" / name)


def test_the_train_a_rule_tutorial_runs_as_written_at_a_smaller_size(tmp_path, monkeypatch):
    from box2d_driving.cli import main as cli

    commands, _ = _tutorial("train-a-rule.md")
    assert [c[0] for c in commands] == ["train", "evaluate", "evaluate", "render", "play"]  # the 2nd: light-blind
    monkeypatch.chdir(tmp_path)  # the tutorial's relative paths (runs/lights, lights.mp4) land here
    for argv in commands[:-1]:  # play needs a person at the keyboard
        assert cli(argv + _SMALLER[argv[0]]) == 0, argv
    assert (tmp_path / "runs" / "lights" / "model.safetensors").exists()
    # what the tutorial says evaluation writes
    for name in ("metrics.json", "learning_curves.png", "acceleration_by_light.png", "junction_light.png",
                 "collisions.png", "rollouts.npz"):
        assert (tmp_path / "runs" / "lights" / "eval" / name).exists(), name
    assert (tmp_path / "lights.mp4").stat().st_size > 0
    assert (tmp_path / "runs" / "full-throttle" / "metrics.json").exists()  # the light-blind reference
    from box2d_driving.policies import load_trained  # "the policy runs without torch as well"

    assert load_trained("runs/lights") is not None


def test_the_single_agent_tutorial_runs_as_written():
    _, blocks = _tutorial("single-agent.md")
    namespace: dict = {}
    exec(compile(blocks[0], "single-agent.md", "exec"), namespace)  # make, reset, step as written
    # the SB3 block at a smaller size: one short rollout of the same PPO on the same env
    assert "model.learn(50_000)" in blocks[1] and 'PPO("MlpPolicy", env, seed=0, verbose=1)' in blocks[1]
    smaller = (blocks[1].replace("50_000", "64").replace("verbose=1)", "verbose=0, n_steps=64, batch_size=32)")
               .replace("range(20)", "range(2)"))
    exec(compile(smaller, "single-agent.md", "exec"), namespace)
    assert namespace["model"].num_timesteps >= 64 and 0 <= namespace["arrived"] <= 2


def test_the_ray_cluster_tutorials_commands_are_valid_sweeps_and_its_reader_runs(tmp_path, monkeypatch, capsys):
    import shutil

    from training.sweeps.spec import check_spec
    from training.sweeps.sweep import build_parser, spec_from_args

    commands, reader = _tutorial("ray-cluster.md")
    assert [c[0] for c in commands] == ["sweep", "sweep"]
    for argv in commands:  # what Ray would be handed: the options parse and every trial's config is valid
        spec, _ = spec_from_args(build_parser().parse_args(argv[1:]))
        check_spec(spec)
    # the reader, as written, on a real sweep summary put where the tutorial's sweep writes its own
    (tmp_path / "runs" / "sweep-lights").mkdir(parents=True)
    shutil.copy(ROOT / "assets" / "sweeps" / "lights.csv", tmp_path / "runs" / "sweep-lights" / "summary.csv")
    monkeypatch.chdir(tmp_path)
    assert len(reader) == 1
    exec(compile(reader[0], "ray-cluster.md", "exec"), {})
    printed = capsys.readouterr().out.splitlines()
    assert printed and all(re.fullmatch(r"\S+ \d\.\d{3} ± \d\.\d{3}", line) for line in printed), printed


def test_the_osm_tutorial_runs_as_written_on_a_small_extract(tmp_path, monkeypatch):
    from box2d_driving.cli import main as cli
    from osm_fixtures import four_way

    commands, blocks = _tutorial("osm-junction.md")
    assert [c[0] for c in commands] == ["import-osm", "train"]
    importer, train = commands
    # the extract: a hand-built four-way junction placed at the tutorial's latitude/longitude, as
    # OSM XML (the tutorial: "any .osm.pbf or .osm XML file works")
    lat, lon = (float(v) for v in importer[importer.index("--latlon") + 1].split(","))
    monkeypatch.chdir(tmp_path)
    four_way(tmp_path / "city.osm", origin=(lat, lon))
    assert cli([importer[0], "city.osm", *importer[2:]]) == 0
    assert (tmp_path / "my_junction.json").exists() and (tmp_path / "my_junction.png").stat().st_size > 0
    assert len(blocks) == 1
    namespace: dict = {}
    exec(compile(blocks[0], "osm-junction.md", "exec"), namespace)  # drive on it
    assert len(namespace["observations"]) == 8
    assert cli(train + _SMALLER["train"]) == 0
    assert (tmp_path / "runs" / "mine" / "model.safetensors").exists()


def _documented_commands() -> list[tuple[str, list[str]]]:
    """Every ``box2d-driving ...`` command the user-facing text shows (code blocks and inline
    code), as (where, words after the program name); synopsis brackets and bars become spaces."""
    found = []
    for path in _user_facing():
        if path.suffix != ".md":
            continue
        text = path.read_text()
        lines = _examples(text)[0] + [span.strip() for span in re.findall(r"`(box2d-driving [^`]*)`", text)]
        for line in lines:
            words = re.sub(r"[\[\]|]", " ", line).split()[1:]
            found.append((f"{path.relative_to(ROOT)}: {line[:80]}", words))
    return found


def test_every_documented_command_uses_only_options_its_command_has(capsys):
    from box2d_driving import plugins
    from box2d_driving.cli import build_parser
    from box2d_driving.cli import main as cli

    commands, behaviours = build_parser().commands, plugins.behaviours()
    known: dict[tuple[str, ...], set[str]] = {}
    unknown, checked = [], 0
    for where, words in _documented_commands():
        if not words or words[0] not in commands:
            continue  # a placeholder such as `box2d-driving COMMAND`
        key = tuple(words[:1])
        if words[0] == "train":
            if len(words) < 2 or words[1] not in behaviours:
                continue  # `train BEHAVIOUR ...`
            key = tuple(words[:2])
        elif words[0] == "original" and len(words) > 1:  # setup / train / compare: parsers of their own
            key = tuple(words[:2])
        elif words[0] == "bench":  # its modes have parsers of their own
            key += tuple(w for w in words if w in ("--train", "--memory"))[:1]
        if key not in known:
            with pytest.raises(SystemExit):
                cli([*key, "--help"])
            known[key] = set(re.findall(r"--[a-z][a-z0-9-]*", capsys.readouterr().out))
            assert "--help" in known[key], key
        checked += 1
        unknown += [f"{where} -> {w}" for w in words if w.startswith("--") and w.split("=")[0] not in known[key]]
    assert checked > 100 and not unknown, "\n".join(unknown)


# Python blocks that read what an earlier step of their page makes get it made first, by that step at
# a smaller size: the README's training command, whose run also stands in for a sweep trial's run
# folder (the same layout), and one shrink of an episode count (smaller, never different).
_SWEEP_TRIAL_RUN = "runs/sweep-lights-paper/tune/lights_lidar_noise=1.0_seed=0/run"
_SMALLER_BLOCK = {"policy, 200, seed=": "policy, 2, seed="}


def test_every_python_example_on_the_pages_runs(tmp_path, monkeypatch):
    import shutil

    from box2d_driving.cli import main as cli

    monkeypatch.chdir(tmp_path)  # what an example writes lands here; the shipped assets are where it looks
    (tmp_path / "assets").symlink_to(ROOT / "assets")
    readme_commands, _ = _commands_and_blocks(ROOT / "README.md")
    train = next(argv for argv in readme_commands if argv[-2:] == ["--out", "runs/lights4"])
    assert cli(train + _SMALLER["train"]) == 0
    shutil.copytree("runs/lights4", _SWEEP_TRIAL_RUN)
    ran = []
    for path in _user_facing():
        if path.suffix != ".md" or "tutorials" in path.parts:
            continue
        for n, block in enumerate(_examples(path.read_text())[1]):
            for old, smaller in _SMALLER_BLOCK.items():
                block = block.replace(old, smaller)
            exec(compile(block, f"{path.relative_to(ROOT)} (example {n + 1})", "exec"), {})
            ran.append(f"{path.name}:{n + 1}")
    assert len(ran) >= 14, ran
    assert (tmp_path / "map.json").exists()  # the OSM import example, from the shipped extract


class _Page:  # what the docs hooks read of an mkdocs page
    class file:
        src_uri = "layout.md"


def test_the_layout_page_lists_every_module_by_its_docstring():
    """docs/layout.md's module tables are generated from the code when the site is built; every
    module needs a docstring whose first sentence says what it is, or its row is empty."""
    import importlib.util

    spec = importlib.util.spec_from_file_location("docs_hooks", ROOT / "docs" / "hooks.py")
    hooks = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(hooks)
    page = (ROOT / "docs" / "layout.md").read_text(encoding="utf-8")
    for package in ("box2d_driving", "training", "tests"):
        assert f"<!-- generated: modules {package} -->" in page
        summaries = hooks.module_summaries(package)
        files = {p.relative_to(ROOT / package).as_posix() for p in (ROOT / package).rglob("*.py")} - {"__main__.py"}
        assert set(summaries) == files and len(files) > 20, package
        assert not [m for m, s in summaries.items() if len(s) < 15], f"{package}: modules without a docstring sentence"
        table = hooks.on_page_markdown(f"<!-- generated: modules {package} -->", _Page(), None, None)
        assert all(f"| `{m}` |" in table for m in files)



def test_every_info_key_of_every_scenario_is_documented():
    """The scenario pages print ``INFO_FIELDS`` (and a scenario's own ``scenario_info_fields``):
    a key added to ``car_infos`` or ``scenario_info`` without its meaning fails here."""
    import box2d_driving
    from box2d_driving.envs.core import INFO_FIELDS

    for env_id in box2d_driving.registry():
        env = box2d_driving.make(env_id, communication=True) if env_id == "real-junction-v0" else \
            box2d_driving.make(env_id)
        _, infos = env.reset(seed=0)
        _, _, _, _, stepped = env.step({a: 0 for a in env.agents})
        keys = set().union(*(set(i) for i in list(infos.values()) + list(stepped.values())))
        undocumented = keys - set(INFO_FIELDS) - set(env.scenario_info_fields)
        env.close()
        assert not undocumented, (env_id, undocumented)
