"""The dashboard's own pane classes, against Panel's."""

import panel as pn
from bokeh.document import Document

from app.dashboard import TextHTML, _alert


def _model(pane):
    doc = Document()
    return pane.get_root(doc)


def test_text_html_sends_the_text_panels_html_pane_sends_and_nothing_else(monkeypatch):
    texts = [_alert("first <b>not bold</b>", "warning"), _alert("second & third\nline", "danger"), ""]
    ours, panels = TextHTML(texts[0]), pn.pane.HTML(texts[0])
    ours_model, panels_model = _model(ours), _model(panels)
    recomputed = []
    monkeypatch.setattr(TextHTML, "_get_properties",
                        lambda self, doc: recomputed.append(doc) or pn.pane.HTML._get_properties(self, doc))
    changes = []
    ours_model.on_change("text", lambda attr, old, new: changes.append(attr))
    for text in texts[1:]:
        changes.clear()
        ours.object = panels.object = text
        assert ours_model.text == panels_model.text
        assert changes == ["text"]
    assert recomputed == []  # Panel's own works out every property again
