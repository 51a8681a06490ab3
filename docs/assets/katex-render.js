// Typesets the equations of the page with KaTeX (served by the site: docs/hooks/katex.py).
// pymdownx.arithmatex (generic mode) writes $...$ as <span class="arithmatex">\(...\)</span> and
// $$...$$ as <div class="arithmatex">\[...\]</div>. An equation KaTeX cannot parse is left as
// written and reported on the console (the site's browser test fails on console errors).
(function () {
  "use strict";
  function typeset(root) {
    root.querySelectorAll(".arithmatex").forEach(function (el) {
      if (el.dataset.typeset) return;
      var tex = el.textContent.trim();
      var display = el.tagName === "DIV";
      tex = tex.replace(/^\\[\[(]/, "").replace(/\\[\])]$/, "");
      try {
        katex.render(tex, el, { displayMode: display, throwOnError: true, output: "htmlAndMathml" });
        el.dataset.typeset = "1";
      } catch (err) {
        console.error("KaTeX: " + err.message + " in: " + tex);
      }
    });
  }
  if (typeof document$ !== "undefined") {
    document$.subscribe(function () { typeset(document.body); });  // (Material's page event)
  } else {
    document.addEventListener("DOMContentLoaded", function () { typeset(document.body); });
  }
})();
