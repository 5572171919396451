// An inline formula wider than its column scrolls inside its own box (course.css,
// span.math.course-wide); every other one stays inline, without the scroll bar that the
// few pixels its glyphs overhang MathJax's box would otherwise show (a classic scroll bar,
// as on Windows and Linux). Marked once MathJax has typeset the page, again on resize and
// when a fold opens (closed, its formulas have no width).
(function () {
  function mark() {
    document.querySelectorAll("span.math").forEach(function (s) {
      var column = s.parentElement.closest("p, li, td, th, dd, dt, div, blockquote, section");
      if (!column) return;
      // narrower than its column, a formula fits on a line of its own: no scroll box
      s.classList.toggle("course-wide", s.scrollWidth > column.clientWidth);
    });
  }
  function whenTypeset() {
    var mj = window.MathJax;
    var ready = mj && mj.startup && mj.startup.promise ? mj.startup.promise : Promise.resolve();
    ready.then(mark);
    if (document.fonts) document.fonts.ready.then(mark);
  }
  window.addEventListener("load", whenTypeset);
  window.addEventListener("resize", mark);
  document.addEventListener("toggle", mark, true);   // a fold opened: its formulas measured
})();
