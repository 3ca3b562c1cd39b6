// fit.test.mjs: checks fit.js, the page's reading of a head's fit report: the paths it
// fetches, the numbers as shown (mm, one decimal, "–" for a missing one), the region
// table, the warnings, and what each answer of `GET /v1/heads/{id}/fit` shows (an older
// server's 404: nothing). Run `node web/fit.test.mjs`; the exit status is the verdict.
// Not served: the page never loads this file.

import { fitOutcome, fitPaths, formatFit, oneDecimal } from "./fit.js";

const failures = [];

function same(actual, expected, path) {
  if (JSON.stringify(actual) !== JSON.stringify(expected)) {
    failures.push(`${path}: ${JSON.stringify(actual)} != ${JSON.stringify(expected)}`);
  }
}

/** A report as the server sends it (core/src/fit/report.rs), with the fields the page ignores. */
const report = {
  mm_per_unit: 10.0,
  surface: { mean_mm: 1.5, max_mm: 5.8, worst_mask_vertex: 0, count: 113 },
  regions: [
    { region: "eyes", mean_mm: 1.1, max_mm: 3.24, worst_mask_vertex: 20, count: 36 },
    { region: "brow", mean_mm: 0.04, max_mm: 0.96, worst_mask_vertex: 3, count: 10 },
    { region: "forehead_and_cheeks", mean_mm: 2.25, max_mm: 5.8, worst_mask_vertex: 0, count: 30 },
    { region: "jaw", mean_mm: 0, max_mm: 0, worst_mask_vertex: 0, count: 0 },
  ],
  inner_lip_gap_mm: 0.81,
  warnings: [
    { kind: "lips_apart_at_rest", gap_mm: 5.8, message: "the inner lips are 5.8 mm apart at rest: registering the head closes them (raising the jaw until they meet) so that p, b and m can" },
    { kind: "no_head_under", region: "jaw", mask_vertices: [1, 2] },
    { kind: "far_from_surface", message: "" },
    "not a warning",
  ],
};

// Paths: on the node in use (nodes.js adds it), the head's id escaped.
same(fitPaths("scan"), { report: "/v1/heads/scan/fit", front: "/v1/heads/scan/fit.png?view=front", side: "/v1/heads/scan/fit.png?view=side" }, "paths");
same(fitPaths("a b/c").report, "/v1/heads/a%20b%2Fc/fit", "path escapes the id");

// Numbers: one decimal, no "-0.0", "–" for what is not a finite number.
same([1.5, 0.81, 3.25, 12, -0.04, -1.26, 0].map(oneDecimal), ["1.5", "0.8", "3.3", "12.0", "0.0", "-1.3", "0.0"], "one decimal");
same([null, undefined, NaN, Infinity, "1.5", {}].map(oneDecimal), ["–", "–", "–", "–", "–", "–"], "not numbers");

// The report as shown.
same(
  formatFit(report),
  {
    overall: "mean 1.5 mm, max 5.8 mm",
    regions: [
      { name: "eyes", mean: "1.1", max: "3.2" },
      { name: "brow", mean: "0.0", max: "1.0" },
      { name: "forehead and cheeks", mean: "2.3", max: "5.8" },
      { name: "jaw", mean: "–", max: "–" },
    ],
    lipGap: "0.8 mm",
    warnings: ["the inner lips are 5.8 mm apart at rest: registering the head closes them (raising the jaw until they meet) so that p, b and m can", "no_head_under", "far_from_surface"],
  },
  "report",
);

// A report with fields missing (another server version) shows what it has and never throws.
same(
  formatFit({ surface: { mean_mm: 2 }, regions: [null, { region: "nose" }], inner_lip_gap_mm: null }),
  { overall: "mean 2.0 mm, max –", regions: [{ name: "?", mean: "–", max: "–" }, { name: "nose", mean: "–", max: "–" }], lipGap: "–", warnings: [] },
  "partial report",
);
// A head whose lips were apart at rest, closed by registration.
same(
  formatFit({ ...report, inner_lip_gap_mm: 0, mouth_closed: { open_mm: 5.84, raised_mm: 6.07 } }).lipGap,
  "0.0 mm (was 5.8 mm; closed at registration, the lower lip raised 6.1 mm)",
  "mouth closed",
);
same(formatFit({ ...report, mouth_closed: null }).lipGap, "0.8 mm", "mouth not closed");
same(formatFit({}), { overall: "mean –, max –", regions: [], lipGap: "–", warnings: [] }, "empty object");
same([null, undefined, 3, "x", []].map(formatFit), [null, null, null, null, null], "not reports");

// What each answer shows.
same(fitOutcome(200, report).kind, "report", "200");
same(fitOutcome(200, report).fit, formatFit(report), "200 report");
same(fitOutcome(200, null).kind, "error", "200 that is not JSON");
same(fitOutcome(404, { error: "unknown_head", message: 'no head "x"' }), { kind: "none" }, "no such head: nothing (the views say it)");
same(fitOutcome(404, { error: "not_found", message: "/v1/heads/x/fit" }), { kind: "none" }, "an older server's 404: nothing");
same(fitOutcome(404, null), { kind: "none" }, "a 404 that is not JSON: nothing");
same(fitOutcome(405, null), { kind: "none" }, "405: nothing");
{
  const registering = fitOutcome(503, { error: "registering", message: 'head "x" is still registering (40 %)' });
  same(registering.kind, "note", "registering");
  same(registering.text.includes("registering"), true, "registering says so");
  const failed = fitOutcome(409, { error: "registration_failed", message: "..." });
  same(failed.kind, "note", "registration failed");
  same(failed.text.includes("failed"), true, "registration failed says so");
}
same(fitOutcome(503, { error: "bus_unavailable" }), { kind: "error", text: "Cannot read the fit report (HTTP 503: bus_unavailable)." }, "other 503");
same(fitOutcome(401, { error: "unauthorized" }), { kind: "error", text: "Cannot read the fit report (HTTP 401: unauthorized)." }, "401");
same(fitOutcome(500, null), { kind: "error", text: "Cannot read the fit report (HTTP 500)." }, "500 without a body");

if (failures.length > 0) {
  console.error(`${failures.length} mismatch(es):\n${failures.join("\n")}`);
  process.exit(1);
}
console.log("fit.js reads the fit report and every answer of its endpoint");
