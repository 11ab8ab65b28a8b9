"""What a page says when its server goes away (stopped, restarted, crashed): at once, that the
server is gone, that nothing changed on the page is computed any more, and that a reload with the
page's address brings back the scenario last applied (the address holds it: app/state/url.py); then,
when the server answers again, a button that reloads with that address (issue 46, defect 1: a
page left open across a restart went dead without a word, its boxes taking values that were
never applied).

Public means only: Bokeh's document event ``connection_lost`` (BokehJS sends it to the
document when the websocket closes) with a ``CustomJS`` callback, and the server's ``/liveness``
(``panel serve --liveness``); a server started without it answers 404 there, which still says it
is back.
"""

from __future__ import annotations

from bokeh.models import CustomJS

#: Seconds between the gone page's checks that the server is back.
POLL_S = 2.0

#: The banner's CSS class (tests find it by it).
BANNER_CLASS = "server-gone"

GONE = ("The server is gone (stopped or restarted): this page no longer computes, and a value "
        "changed here is not applied. Reload the page when the server is back: its address keeps "
        "the scenario last applied.")
BACK = "The server is back."
RELOAD = "Reload with the last applied scenario"

_JS = """
if (document.querySelector("." + banner_class)) return;  // said once per page
const bar = document.createElement("div");
bar.className = banner_class;
bar.setAttribute("role", "alert");
bar.style.cssText = "position:fixed;top:0;left:0;right:0;z-index:100000;padding:10px 16px;" +
  "font:15px/1.4 sans-serif;color:#fff;background:#a4000f;box-shadow:0 2px 6px rgba(0,0,0,.3)";
const text = document.createElement("span");
const scenario = window.location.search ? " (" + decodeURIComponent(window.location.search) + ")" : " (the defaults)";
text.textContent = gone + scenario;
bar.appendChild(text);
document.body.appendChild(bar);
const liveness = new URL("liveness", window.location.href).href;
const poll = () => fetch(liveness, {cache: "no-store"}).then((r) => {
  if (r.status >= 500) return setTimeout(poll, poll_ms);  // a proxy's "no upstream": still gone
  bar.style.background = "#1b5e20";
  text.textContent = back + " Its last applied scenario" + scenario + " is in this page's address. ";
  const button = document.createElement("button");
  button.textContent = reload;
  button.style.cssText = "margin-left:8px;font:inherit;padding:2px 10px;cursor:pointer";
  button.onclick = () => window.location.reload();  // the address: the last applied scenario
  bar.appendChild(button);
}).catch(() => setTimeout(poll, poll_ms));
setTimeout(poll, poll_ms);
"""


def watch_connection(doc):
    """Give the session's document ``doc`` the banner for a lost server (module notes)."""
    if doc is None:
        return
    doc.js_on_event("connection_lost", CustomJS(
        args=dict(banner_class=BANNER_CLASS, gone=GONE, back=BACK, reload=RELOAD,
                  poll_ms=int(POLL_S * 1000)), code=_JS))
