// fit.js: the chosen head's fit report (`GET /v1/heads/{id}/fit`: how far the mask sits
// from the head's surface, overall and per region, the inner-lip gap at rest, warnings) as
// the text the page shows, and what each answer of that endpoint means for the page. An
// older server has no such endpoint: its 404 shows nothing. No DOM: node tests it
// (fit.test.mjs); app.js puts the result in the page.

/**
 * Head `id`'s report and its two pictures (800x800 PNGs of the fitted mask on the head),
 * as paths: nodes.js puts them on the node in use, as for every other fetch.
 */
export function fitPaths(id) {
  const report = `/v1/heads/${encodeURIComponent(id)}/fit`;
  return { report, front: `${report}.png?view=front`, side: `${report}.png?view=side` };
}

/**
 * `value` (mm) with one decimal; "–" for anything else, so a field missing from a newer or
 * older server's report shows as unknown instead of throwing. No "-0.0" for a tiny
 * negative value.
 */
export function oneDecimal(value) {
  if (typeof value !== "number" || !Number.isFinite(value)) {
    return "–";
  }
  const rounded = Math.round(value * 10) / 10;
  return (rounded === 0 ? 0 : rounded).toFixed(1);
}

/** `value` (mm) as "1.5 mm", or "–". */
function millimetres(value) {
  const text = oneDecimal(value);
  return text === "–" ? text : `${text} mm`;
}

/** A region's id as words: `forehead_and_cheeks` is "forehead and cheeks". */
function regionName(region) {
  return typeof region === "string" && region ? region.replaceAll("_", " ") : "?";
}

/**
 * A region's mean and max (mm, one decimal); "–" for a region with no mask vertex, whose
 * zeros measure nothing.
 */
function regionRow(r) {
  const empty = r?.count === 0;
  return {
    name: regionName(r?.region),
    mean: empty ? "–" : oneDecimal(r?.mean_mm),
    max: empty ? "–" : oneDecimal(r?.max_mm),
  };
}

/**
 * The inner-lip gap at rest as shown: "0.0 mm", or for a head registration closed (its
 * lips were apart at rest) "0.0 mm (was 5.8 mm; closed at registration, the lower lip
 * raised 6.1 mm)".
 */
function lipGap(report) {
  const gap = millimetres(report.inner_lip_gap_mm);
  const closed = report.mouth_closed;
  if (closed === null || typeof closed !== "object") {
    return gap;
  }
  return `${gap} (was ${millimetres(closed.open_mm)}; closed at registration, the lower lip raised ${millimetres(closed.raised_mm)})`;
}

/**
 * The report as the page shows it: { overall, regions: [{ name, mean, max }] (mm, one
 * decimal, the server's order), lipGap, warnings: [message] }, or null when `report` is not
 * a report at all. A warning without a message shows its kind, so none is lost.
 */
export function formatFit(report) {
  if (report === null || typeof report !== "object" || Array.isArray(report)) {
    return null;
  }
  const surface = report.surface ?? {};
  const regions = Array.isArray(report.regions) ? report.regions : [];
  const warnings = Array.isArray(report.warnings) ? report.warnings : [];
  return {
    overall: `mean ${millimetres(surface.mean_mm)}, max ${millimetres(surface.max_mm)}`,
    regions: regions.map(regionRow),
    lipGap: lipGap(report),
    warnings: warnings.map((w) => w?.message || w?.kind || "").filter((text) => typeof text === "string" && text),
  };
}

/**
 * What the page does with the endpoint's answer: HTTP `status` and its JSON `body` (null
 * when it was not JSON). `{ kind: "report", fit }` (formatFit's), `{ kind: "none" }` (show
 * nothing: an older server without the endpoint, or no such head, which the views already
 * say), `{ kind: "note", text }` (no report yet or ever: registering, failed) or
 * `{ kind: "error", text }` (worth trying again later).
 */
export function fitOutcome(status, body) {
  const code = typeof body?.error === "string" ? body.error : "";
  if (status === 200) {
    const fit = formatFit(body);
    return fit ? { kind: "report", fit } : { kind: "error", text: "Cannot read the fit report: the answer is not a report." };
  }
  if (status === 404 || status === 405) {
    return { kind: "none" };
  }
  if (status === 503 && code === "registering") {
    return { kind: "note", text: "The head is still registering; its fit report comes once it is ready." };
  }
  if (status === 409 && code === "registration_failed") {
    return { kind: "note", text: "The head's registration failed: no fit report." };
  }
  return { kind: "error", text: `Cannot read the fit report (HTTP ${status}${code ? `: ${code}` : ""}).` };
}
