/* pfrepro book: every figure in the text opens at full size when tapped or clicked.
 * On a phone a multi-panel figure is shown at a fraction of its size; the link to the image
 * itself lets the reader zoom into it (tests/browser/check_pages.py accepts such a link as the
 * answer to small figure text below its phone breakpoint). */
document.addEventListener("DOMContentLoaded", () => {
  document.querySelectorAll("article.bd-article img").forEach((img) => {
    if (img.closest("a") || img.closest("div.pf-figure")) return;  // those have an Enlarge button
    const a = document.createElement("a");
    a.href = img.getAttribute("src");
    a.className = "pf-enlarge";
    a.title = "Open the figure at full size";
    img.parentNode.insertBefore(a, img);
    a.appendChild(img);
  });
});
