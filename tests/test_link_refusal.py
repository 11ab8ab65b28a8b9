"""A pasted link is taken whole or not at all (issue 40 defect 1 and the low link items).

The defect: ``/app?sea_model=layered&sea_depth=80&h=100`` said "Link values refused, defaults
kept" yet showed a layered sea of 80 m with z = h = 80 m, and left the address bar empty. The
link was read twice: the first read switched the sea and moved h to the seabed, the second saw
h = 100 below that seabed and refused, leaving the first read's values in place. Here the link
is read as the page reads it (app.state.url.sync_url with Panel's own Location).
"""

from urllib.parse import parse_qs

import pytest
from panel.io.location import Location

from app.state.scenario import PART_OF, Scenario
from app.state.url import query, read_link, sync_url

TITLES = ("Maps", "Layout design", "Track", "Calibration", "Shape")


def _args(search):
    return {k: [v.encode() for v in vs]
            for k, vs in parse_qs(search.lstrip("?"), keep_blank_values=True).items()}


def _open(search):
    """A Scenario opened from ``search`` as the page opens it; its Location."""
    scenario, location = Scenario(), Location(search=search)
    sync_url(scenario, location, _args(search), titles=TITLES)
    return scenario, location


def _inputs(s):
    return {n: s.value(n) for n in PART_OF}


@pytest.mark.parametrize("search, key, why", [
    ("?sea_model=layered&sea_depth=80&h=100", "h", "Station depth h (m) = 100 m is outside the water column 0 … 80 m"),
    ("?sea_model=layered&sea_depth=50&z=120", "z", "Target depth z (m) = 120 m is outside the water column 0 … 50 m"),
    ("?Ph=250&h=1e9", "h", "h:"),
    ("?Ph=250&Ph=300", "Ph", "given 2 times"),
])
def test_a_refused_link_sets_nothing_says_which_key_and_why_and_the_address_shows_the_view(search, key, why):
    s, location = _open(search)
    assert _inputs(s) == _inputs(Scenario())  # nothing of the link: not the sea, not its depth
    assert s.message.startswith("Link refused, nothing of it applied")
    assert f"{key}:" in s.message and why in s.message
    assert s.refused == []  # about the link: shown at the top of the page
    assert location.search == ""  # the view shown is the defaults'


def test_a_layered_link_that_fits_is_taken_whole_and_its_given_values_are_not_moved():
    s, location = _open("?sea_model=layered&sea_depth=80&h=60&z=30")
    assert (s.medium.sea_model, s.medium.sea_depth, s.stations.h, s.target.z) == ("layered", 80, 60, 30)
    assert s.stations.stations == [[st[0], st[1], 80.0] for st in Scenario().stations.stations]
    again, _ = _open(location.search)  # the address bar's link reopens the same view
    assert _inputs(again) == _inputs(s)


def test_a_layered_sea_at_the_default_station_depth_round_trips():
    # h = 100 m is the default: the link must carry it, else reopening moved h to the seabed
    s = Scenario()
    s.medium.sea_model = "layered"
    s.stations.h = 100.0
    again, _ = _open(query(s))
    assert _inputs(again) == _inputs(s) and again.message == ""


def test_unknown_keys_and_a_bad_tab_are_ignored_and_said_and_leave_the_address_bar():
    s, location = _open("?Ph=250&colour=red&tab=Nowhere")
    assert s.target.Ph == 250
    assert "'colour' (not an input of this page)" in s.message
    assert "tab 'Nowhere'" in s.message and "Maps, Layout design" in s.message
    assert parse_qs(location.search.lstrip("?")) == {"Ph": ["250"]}


@pytest.mark.parametrize("asked", ["track", "TRACK", "Track", "%20track"])
def test_the_tab_name_is_matched_without_case(asked):
    link = read_link(Scenario(), _args(f"?tab={asked}"), TITLES)
    assert link.tab == "Track" and link.ignored == []


def test_a_link_longer_than_the_page_opens_is_refused_whole_and_said():
    # issue 46 defect 5: a 74 KB link got an empty response; one that reaches the page over
    # MAX_LINK_CHARS is refused whole, with its length and the limit
    from app.state.url import MAX_LINK_CHARS

    search = "?Ph=250&cal_headings=" + "+".join(["1"] * (MAX_LINK_CHARS // 2))
    s, location = _open(search)
    assert _inputs(s) == _inputs(Scenario()) and location.search == ""
    assert s.message.startswith("Link refused, nothing of it applied")
    assert f"{len(search) - 1:,} characters long" in s.message and f"{MAX_LINK_CHARS:,}" in s.message


def test_the_pages_own_longest_link_is_far_below_the_limit():
    """Every input at its longest (8 stations at the edge, 72 headings, 20 outliers, every
    number with its digits): the link the page writes stays under 3,000 characters, so the
    limit refuses only links the page did not make."""
    from app.state.url import MAX_LINK_CHARS

    s = Scenario()
    s.update(stations=[[-4999.9, -4999.9, 4999.9]] * 8)
    s.update(cal_headings=", ".join(["-359.99"] * 72), shape_outliers=", ".join(["-99.5"] * 20))
    longest = 0
    for n in PART_OF:  # every number with its digits, where the other values let it be
        accepted = type(s.part_of(n)).accepted.get(n)
        if isinstance(s.value(n), float) and accepted:
            lo, hi, _ = accepted
            s.update({n: lo + (hi - lo) * 0.123456789})
            longest += s.value(n) == lo + (hi - lo) * 0.123456789
    assert longest >= 50  # of ~60 numbers
    link = query(s, "Calibration")
    assert s.values()["stations"] == [[-4999.9, -4999.9, 4999.9]] * 8 and "cal_headings" in link
    assert len(link) < 3000 < MAX_LINK_CHARS, len(link)
