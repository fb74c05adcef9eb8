/* pfrepro book: figures drawn for the laptop and for the phone (pfrepro.plotting.responsive).
 * The browser picks the drawing for its width (<picture>); the "Enlarge" button under each
 * figure opens the laptop drawing at its full size in an overlay that scrolls, closed by a tap,
 * a click or Escape. Nothing is loaded: both drawings are in the page. */
document.addEventListener("DOMContentLoaded", () => {
  let overlay = null;
  const close = () => { if (overlay) { overlay.remove(); overlay = null; } };
  document.addEventListener("keydown", (e) => { if (e.key === "Escape") close(); });
  document.querySelectorAll("div.pf-figure").forEach((box) => {
    const img = box.querySelector("img.pf-figure-img");
    const button = box.querySelector("button.pf-enlarge");
    if (!img || !button) return;
    button.setAttribute("aria-label", "Enlarge the figure: " + (img.alt || ""));
    button.addEventListener("click", () => {
      close();
      overlay = document.createElement("div");
      overlay.className = "pf-figure-overlay";
      overlay.setAttribute("role", "dialog");
      overlay.setAttribute("aria-label", "Figure at full size (tap or press Escape to close)");
      const big = document.createElement("img");
      big.src = img.getAttribute("src");  // the laptop drawing, at its natural size
      big.alt = img.alt;
      overlay.appendChild(big);
      overlay.addEventListener("click", close);
      document.body.appendChild(overlay);
    });
  });
});
