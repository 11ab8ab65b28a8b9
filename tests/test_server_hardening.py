"""The served dashboard refuses what it must: foreign websocket origins, absurd links, markup.

Bokeh checks the Origin header in the websocket handshake (``check_origin``), before it looks at
the session token: a foreign origin gets HTTP 403 whatever the token; the allowed origin with a
valid (unsigned) token completes the handshake and receives the server's ACK.
"""

import asyncio
import json
import os
import time

import pytest
from bokeh.util.token import generate_jwt_token, generate_session_id
from tornado.httpclient import HTTPClientError, HTTPRequest
from tornado.websocket import websocket_connect

from app.state.scenario import ACCEPTED, Scenario
from support.page import CHROMIUM, chromium_browser
from support.server import close_websocket, served_app


@pytest.fixture(scope="module")
def server():
    os.environ.setdefault("QUIET_SERVER", "1")
    with served_app() as (url, _):
        yield url


# -- unit level: the grid is capped whatever the route ------------------------------------------

@pytest.mark.parametrize("value", [401, 100_000, 10**9, 0, -5, 19])
def test_resolution_outside_limits_is_refused(value):
    s = Scenario()
    s.region.resolution = value
    assert s.region.resolution == 200 and "Grid points per axis" in s.message
    s2 = Scenario(resolution=value)  # also when given to the constructor
    assert s2.region.resolution == 200 and "Grid points per axis" in s2.message
    assert s2.snapshot().core_plane().n == 200


def test_resolution_limit_is_400():
    assert ACCEPTED["resolution"][1] == 400
    s = Scenario()
    s.region.resolution = 400
    assert s.region.resolution == 400 and s.message == ""


# -- websocket origin ---------------------------------------------------------------------------

async def _handshake(url, origin):
    token = generate_jwt_token(generate_session_id())
    request = HTTPRequest(url.replace("http://", "ws://") + "/app/ws", headers={"Origin": origin},
                          request_timeout=60)
    ws = await websocket_connect(request, subprotocols=["bokeh", token])
    try:
        header = await asyncio.wait_for(ws.read_message(), 60)  # first frame of the ACK message
        return json.loads(header)["msgtype"]
    finally:
        await close_websocket(ws)


def test_foreign_websocket_origin_is_refused(server):
    with pytest.raises(HTTPClientError) as err:
        asyncio.run(_handshake(server, "http://evil.example"))
    assert err.value.code == 403


def test_allowed_websocket_origin_is_accepted(server):
    assert asyncio.run(_handshake(server, server)) == "ACK"


# -- absurd links in a real browser -------------------------------------------------------------

playwright = pytest.importorskip("playwright.sync_api")
browser_only = pytest.mark.skipif(not os.path.exists(CHROMIUM) and not os.environ.get("CI"),
                                  reason="Debian's chromium is not installed")

#: Every element, including those inside (open) shadow roots, where Bokeh and Panel render.
INJECTED_JS = """() => {
  const found = [];
  const walk = (root) => {
    for (const el of root.querySelectorAll('*')) {
      if (el.shadowRoot) walk(el.shadowRoot);
      const tag = el.tagName;
      if ((tag === 'IMG' && el.getAttribute('src') === 'x') || el.hasAttribute('onerror') ||
          (tag === 'SCRIPT' && el.textContent.includes('alert(')) || tag === 'MARQUEE')
        found.push(el.outerHTML.slice(0, 120));
    }
  };
  walk(document);
  return found;
}"""
#: For each map: the number of elements of its value image.
IMAGES_JS = """() => {
  const out = [];
  for (const m of Bokeh.documents[0].all_models)
    if (m.data != null && m.data.image != null && m.data.image.length
        && m.data.x !== undefined) out.push(m.data.image[0].length);
  return out;
}"""
PLOTS_JS = """() => Array.from(Bokeh.documents[0].all_models).filter(m => m.renderers !== undefined
  && m.title !== undefined && m.title !== null && m.renderers.some(r => r.data_source && r.data_source.data && r.data_source.data.image)).length"""

XSS = "<img src=x onerror=alert(1)>"
LINKS = {  # query -> text the message must contain (None: no message; the value is ignored)
    "Ph=abc": "Ph",
    "Ph=1e99": "outside the accepted range",
    "resolution=100000": "Grid points per axis",
    "measure=<script>alert(1)</script>": "measure",
    f"Ph={XSS}": "Ph",
    f"message={XSS}": None,
    "Ph=1e99&resolution=100000&heading=nan&measure=%3Cmarquee%3Ex": "Link refused, nothing of it applied",
}


@pytest.fixture(scope="module")
def chromium():
    with chromium_browser() as browser:
        yield browser



@pytest.mark.parametrize("query", list(LINKS))
@browser_only
def test_absurd_link_falls_back_to_defaults(chromium, server, query):
    page = chromium.new_page(viewport={"width": 1500, "height": 1000})
    dialogs, errors = [], []
    page.on("dialog", lambda d: (dialogs.append(d.message), d.dismiss()))
    page.on("pageerror", lambda e: errors.append(str(e)))
    try:
        page.goto(f"{server}/app?{query}")
        page.wait_for_function("() => window.Bokeh && Bokeh.documents.length > 0", timeout=60_000)
        deadline = time.time() + 60
        while not (page.evaluate(PLOTS_JS) == 3 and page.evaluate(IMAGES_JS).count(200 * 200) >= 3):
            assert time.time() < deadline, f"maps not drawn at 200×200: {page.evaluate(IMAGES_JS)}"
            time.sleep(0.2)
        sizes = page.evaluate(IMAGES_JS)
        assert max(sizes) == 200 * 200, sizes  # never a bigger grid
        expected = LINKS[query]
        alert = page.locator(".alert-danger")
        if expected is None:
            time.sleep(1.0)
            assert not alert.first.is_visible() or alert.first.inner_text().strip() == ""
        else:
            alert.first.wait_for(state="visible", timeout=30_000)
            text = alert.first.inner_text()
            assert expected in text, text
            if "<img" in query and "<img" in text:  # if the value is echoed, it is text
                assert XSS in text
        time.sleep(0.5)
        assert page.evaluate(INJECTED_JS) == []
        assert dialogs == [] and errors == [], (dialogs, errors)
        page.get_by_text("Advanced", exact=True).click()  # its inputs are built when it is opened
        shown = (page.locator(".w-Ph input").first.input_value(),
                 page.locator(".w-resolution input").first.input_value())
        defaults = (("100", "200"), ("100.0", "200"))
        assert shown in defaults, shown  # refused link values are never set, so never shown
    finally:
        page.close()
