// Run by tests/test_site.py in each page of the docs site once it has loaded: what overflows
// horizontally, the words of headings and table headers broken across lines, the equations.
() => {
  const shown = el => el.getClientRects().length > 0;
  const what = el => el.tagName.toLowerCase() + (el.className ? "." + String(el.className).split(" ")[0] : "")
    + " '" + el.textContent.trim().slice(0, 50) + "'";
  const overflow = [];
  const de = document.documentElement;
  if (de.scrollWidth > de.clientWidth + 1) overflow.push(`the page: ${de.scrollWidth} px in ${de.clientWidth}`);
  const boxes = ".md-content pre, .md-content pre > code, .md-content table, .md-content .md-typeset__scrollwrap, "
    + ".md-content div.arithmatex, .md-content .katex-display, .md-content .jp-OutputArea-output";
  for (const el of document.querySelectorAll(boxes)) {
    if (shown(el) && el.scrollWidth > el.clientWidth + 1)
      overflow.push(`${what(el)}: ${el.scrollWidth} px in ${el.clientWidth}`);
  }
  const broken = [];
  const heads = ".md-content h1, .md-content h2, .md-content h3, .md-content h4, .md-content th";
  for (const el of document.querySelectorAll(heads)) {
    if (!shown(el)) continue;
    const walk = document.createTreeWalker(el, NodeFilter.SHOW_TEXT);
    for (let n = walk.nextNode(); n; n = walk.nextNode()) {
      for (const m of n.textContent.matchAll(/[A-Za-z0-9]+/g)) {
        const r = document.createRange();
        r.setStart(n, m.index);
        r.setEnd(n, m.index + m[0].length);
        const tops = new Set(Array.from(r.getClientRects()).filter(x => x.width > 0).map(x => Math.round(x.top)));
        if (tops.size > 1) broken.push(`'${m[0]}' in ${what(el)}`);
      }
    }
  }
  const math = document.querySelectorAll(".arithmatex");
  const raw = Array.from(math).filter(el => !el.querySelector(".katex")).map(el => el.textContent.slice(0, 60));
  // the text outside code and typeset math: a $$, \[ or \( there is an equation left raw
  const prose = document.createTreeWalker(document.querySelector(".md-content") || document.body, NodeFilter.SHOW_TEXT,
    {acceptNode: n => n.parentElement.closest("pre, code, .katex, script, style")
      ? NodeFilter.FILTER_REJECT : NodeFilter.FILTER_ACCEPT});
  let dollars = 0;
  for (let n = prose.nextNode(); n; n = prose.nextNode()) dollars += (n.textContent.match(/\$\$|\\\[|\\\(/g) || []).length;
  return {overflow, broken, equations: math.length, typeset: document.querySelectorAll(".arithmatex .katex").length,
          raw, dollars};
}
