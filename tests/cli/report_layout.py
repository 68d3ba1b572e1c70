"""tests/cli/test-report's checks of the report as Chromium laid it out (report_layout.html).

    report_layout.py extract DOM          the JSON of <pre id="layout"> in a --dump-dom output
    report_layout.py height LAYOUT        the page height in px (for a full-page screenshot)
    report_layout.py grid LAYOUT          the tiny dataset: a grid per theme, >= 2 plots in the
                                          first row of each, page under MAX_HEIGHT px
    report_layout.py few LAYOUT INDEX     the few-instance dataset: "too few instances" in every
                                          comparison row, no p-value; method counters plotted for
                                          their own species only
Exits non-zero with one line saying what is wrong.
"""
import html
import json
import re
import sys

MAX_HEIGHT = 6000  # px at 1400 px; the one-column report of the tiny dataset was 9,655 px


def fail(message):
    sys.exit("test-report: " + message)


def extract(dom_path):
    dom = open(dom_path, encoding="utf-8").read()
    m = re.search(r'<pre id="layout">(.*?)</pre>', dom, re.S)
    if not m:
        fail("Chromium wrote no layout into %s" % dom_path)
    layout = json.loads(html.unescape(m.group(1)))
    print(json.dumps(layout))


def grid(layout):
    grids = layout["grids"]
    if len(grids) < 5:
        fail("%d plot grids at 1400 px, expected one per theme (size, branching, crown, leaves, "
             "views, method counters, timing) and the sweeps'" % len(grids))
    narrow = [g for g in grids if g["plots"] >= 2 and g["firstRow"] < 2]
    if narrow:
        fail("at 1400 px, plot grids with fewer than 2 plots in the first row: %s" % narrow)
    if layout["height"] >= MAX_HEIGHT:
        fail("the page is %d px tall at 1400 px (under %d expected)"
             % (layout["height"], MAX_HEIGHT))
    print("test-report: at 1400 px the page is %d px tall; %d plot grids, %s plots in their "
          "first rows" % (layout["height"], len(grids),
                          sorted({g["firstRow"] for g in grids})))


def few(layout, index):
    text = layout["text"]
    start, end = text.find("Species comparison"), text.find("Per-species summary")
    if start < 0 or end < start:
        fail("no species comparison in the page's text")
    rows = [l for l in text[start:end].splitlines() if l.startswith("tiny\t")]
    if not rows:
        fail("no comparison row in the page's text")
    for row in rows:
        cells = row.split("\t")
        if "too few instances" not in cells:
            fail('a comparison row without "too few instances": %s' % cells)
        if any(re.fullmatch(r"\d(\.\d+)?e-\d+|0\.\d+", c) for c in cells[-2:-1]):
            fail("a p-value in %s" % cells)
    page = open(index, encoding="utf-8").read()
    # graph_nodes is iterated-graph's counter (tiny), stems grammar's (grammar-guava).
    plotted = 0
    for metric, has, lacks in [("graph_nodes", "tiny", "grammar-guava"),
                               ("graph_endpoints", "tiny", "grammar-guava"),
                               ("stems", "grammar-guava", "tiny"),
                               ("truncated", "grammar-guava", "tiny")]:
        m = re.search(r'<figure class="plot" data-metric="%s".*?</figure>' % metric, page, re.S)
        if not m:
            continue  # constant for its species: listed, not plotted
        plotted += 1
        fig = m.group(0)
        if 'data-species="%s"' % has not in fig or 'data-species="%s"' % lacks in fig:
            fail("the %s plot should have a row for %s only" % (metric, has))
        if "no value for %s" % lacks not in fig:
            fail("the %s plot does not say that %s has no value" % (metric, lacks))
    if plotted == 0:
        fail("no method counter plotted in the few-instance report")
    print('test-report: report-few: %d comparison rows, each "too few instances"; %d method '
          "counters plotted for their own species only" % (len(rows), plotted))


if __name__ == "__main__":
    what = sys.argv[1]
    if what == "extract":
        extract(sys.argv[2])
    elif what == "height":
        print(json.load(open(sys.argv[2]))["height"])
    elif what == "grid":
        grid(json.load(open(sys.argv[2])))
    elif what == "few":
        few(json.load(open(sys.argv[2])), sys.argv[3])
    else:
        fail("unknown check " + what)
