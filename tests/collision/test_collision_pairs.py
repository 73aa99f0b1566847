"""The disabled-pair analysis: adjacency, always/never by sampling, its file and its cache."""

from __future__ import annotations

import numpy as np
import pytest

from armlab.collision import CollisionScene, analyse_pairs, read_pairs, robot_geometry, write_pairs
from armlab.collision.geometry import urdf_sha256
from armlab.collision.pairs import disabled_pairs
from armlab.errors import InputError
from armlab.robot.model import load_robot, robot_desc_dir

DESC = robot_desc_dir() / "teachbot6"


@pytest.fixture(scope="module")
def bot():
    return load_robot("teachbot6")


@pytest.fixture(scope="module")
def geom(bot):
    return robot_geometry(bot)


def test_teachbot6_collision_geometry_is_its_urdf_collision_elements(geom):
    """The generated URDF has <collision> elements (the drawn primitives): the geometry says
    so, and there is one per <visual> (13)."""
    assert geom.source == "collision"
    assert len(geom.geometry.geometryObjects) == 13


def test_shipped_pairs_file_is_the_analysis_of_the_shipped_urdf(bot, geom):
    """robot_desc/teachbot6/collision_pairs.toml is keyed by the URDF's sha256 and holds what a
    fresh analysis (2000 samples, seed 0) finds: the generator wrote both."""
    shipped = read_pairs(DESC / "collision_pairs.toml")
    assert shipped.urdf_sha256 == urdf_sha256(DESC / "teachbot6.urdf")
    fresh = analyse_pairs(bot, geom, samples=shipped.samples, seed=shipped.seed)
    assert {k: v[0] for k, v in fresh.pairs.items()} == {k: v[0] for k, v in shipped.pairs.items()}


def test_adjacent_pairs_are_the_links_joined_by_one_joint(bot, geom):
    """Every parent-child link pair of the chain is 'adjacent' (base-link1 ... link5-link6)."""
    res = analyse_pairs(bot, geom, samples=50, seed=1)
    adjacent = {k for k, v in res.pairs.items() if v[0] == "adjacent"}
    chain = ["base_link", "link1", "link2", "link3", "link4", "link5", "link6"]
    for a, b in zip(chain[:-1], chain[1:], strict=True):
        assert tuple(sorted((a, b))) in adjacent


def test_never_pairs_stay_apart_in_an_independent_draw(tmp_path, bot, geom):
    """An independent draw of 300 configurations (another seed), every pair checked (an empty
    pairs file): each pair the analysis (500 samples) calls 'never' keeps more than 0 m (the
    margin covers the gaps of the sampling), and the analysis skips some pairs."""
    res = analyse_pairs(bot, geom, samples=500, seed=0)
    never = {k for k, v in res.pairs.items() if v[0] == "never"}
    assert len(never) >= 3
    empty = tmp_path / "none.toml"
    empty.write_text('robot = "teachbot6"\n')
    full = CollisionScene.from_robot(bot, pairs_file=str(empty), geometry=geom)
    links = [tuple(sorted((full.link_of[a], full.link_of[b]))) for a, b in full.pair_names()]
    mins = np.full(full.n_pairs, np.inf)
    for q in bot.random_q(np.random.default_rng(99), 300):
        mins = np.minimum(mins, full.distance_values(q))
    seen = [k for k, pair in enumerate(links) if pair in never]
    assert len(seen) >= len(never)
    assert np.all(mins[seen] > 0.0)
    assert CollisionScene.from_robot(bot, geometry=geom).n_pairs < full.n_pairs


def test_file_round_trip_and_editing_enables_a_pair(tmp_path, bot, geom):
    """write_pairs then read_pairs gives the same pairs; deleting a 'never' entry from the file
    and pointing the scene at it checks that pair again."""
    res = analyse_pairs(bot, geom, samples=200, seed=0)
    path = write_pairs(tmp_path / "pairs.toml", res, "teachbot6", geom.source)
    back = read_pairs(path)
    assert {k: v[0] for k, v in back.pairs.items()} == {k: v[0] for k, v in res.pairs.items()}
    for k, (_, d) in res.pairs.items():
        assert back.pairs[k][1] == pytest.approx(d, abs=1e-6)
    never = sorted(k for k, v in res.pairs.items() if v[0] == "never")[0]
    text = path.read_text()
    block = f'[[disabled]]\na = "{never[0]}"\nb = "{never[1]}"\n'
    assert block in text
    start = text.index(block)
    end = text.find("[[disabled]]", start + 1)
    edited = tmp_path / "edited.toml"
    edited.write_text(text[:start] + (text[end:] if end > 0 else ""))
    before = CollisionScene.from_robot(bot, pairs_file=str(path), geometry=geom)
    after = CollisionScene.from_robot(bot, pairs_file=str(edited), geometry=geom)
    assert after.n_pairs > before.n_pairs
    pairs_after = {
        tuple(sorted((after.link_of[a], after.link_of[b]))) for a, b in after.pair_names()
    }
    assert never in pairs_after


def test_a_near_never_pair_is_checked_at_a_large_clearance(bot, geom):
    """A 'never' pair whose smallest sampled distance is within clearance + margin is checked
    again: the scene at 0.2 m clearance checks more pairs than at 0."""
    at0 = CollisionScene.from_robot(bot, geometry=geom, clearance_m=0.0)
    at200 = CollisionScene.from_robot(bot, geometry=geom, clearance_m=0.2)
    assert at200.n_pairs > at0.n_pairs


def test_cache_is_written_keyed_by_the_urdf_and_reused(tmp_path, monkeypatch):
    """A URDF without a shipped file: the analysis is written to $ARMLAB_CACHE_DIR under the
    robot's name and its sha256, and a second call reads it back (origin 'cache')."""
    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path / "cache"))
    urdf = tmp_path / "arm" / "arm.urdf"
    urdf.parent.mkdir()
    urdf.write_text((DESC / "teachbot6.urdf").read_text().replace('name="teachbot6"', 'name="arm"'))
    robot = load_robot(urdf)
    geom = robot_geometry(robot)
    first = disabled_pairs(robot, geom)
    assert first.origin == "computed"
    cached = tmp_path / "cache" / "collision" / f"arm-{urdf_sha256(urdf)[:16]}.toml"
    assert cached.is_file() and first.path == str(cached)
    second = disabled_pairs(robot, geom)
    assert second.origin == "cache"
    assert {k: v[0] for k, v in second.pairs.items()} == {k: v[0] for k, v in first.pairs.items()}


@pytest.mark.parametrize(
    ("body", "key"),
    [
        ('[[disabled]]\na = "link2"\nb = "nolink"\nreason = "never"\n', "disabled[0].b"),
        ('[[disabled]]\na = "link2"\nb = "link4"\nreason = "maybe"\n', "disabled[0].reason"),
        ("disabled = 3\n", "disabled"),
    ],
)
def test_bad_pairs_file_is_one_line_naming_the_key(tmp_path, bot, geom, body, key):
    path = tmp_path / "pairs.toml"
    path.write_text(body)
    with pytest.raises(InputError) as err:
        CollisionScene.from_robot(bot, pairs_file=str(path), geometry=geom)
    msg = str(err.value)
    assert key in msg and "\n" not in msg


def test_a_urdf_without_collision_elements_falls_back_to_its_visuals(tmp_path, monkeypatch):
    """teachbot6's URDF with its <collision> elements removed: the geometry is its <visual>
    shapes, and the source says so (also on ``armlab info``'s collision line)."""
    import re

    from armlab.cli import main

    monkeypatch.setenv("ARMLAB_CACHE_DIR", str(tmp_path / "cache"))
    text = (DESC / "teachbot6.urdf").read_text()
    stripped = re.sub(r"\s*<collision .*?</collision>", "", text, flags=re.S)
    assert "<collision" not in stripped and "<visual" in stripped
    urdf = tmp_path / "bare.urdf"
    urdf.write_text(stripped)
    geom = robot_geometry(load_robot(urdf))
    assert geom.source == "visual" and len(geom.geometry.geometryObjects) == 13
    assert main(["info", str(urdf)]) == 0


def test_armlab_info_states_the_collision_model(capsys):
    from armlab.cli import main

    assert main(["info", "teachbot6"]) == 0
    out = capsys.readouterr().out
    line = next(x for x in out.splitlines() if x.startswith("collision"))
    assert "13 shapes from the URDF's <collision> elements" in line
    assert "7 adjacent" in line and "collision_pairs.toml" in line
