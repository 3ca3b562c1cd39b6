// nodes.test.mjs: checks nodes.js, the page's list of server nodes: parsing `?nodes=`
// (bad entries dropped with a warning, trailing slashes stripped), round robin failover,
// and the HTTP and WebSocket URLs it builds. Run `node web/nodes.test.mjs`; the exit
// status is the verdict. Not served: the page never loads this file.

import { Nodes, parseNodes } from "./nodes.js";

const failures = [];

function same(actual, expected, path) {
  if (JSON.stringify(actual) !== JSON.stringify(expected)) {
    failures.push(`${path}: ${JSON.stringify(actual)} != ${JSON.stringify(expected)}`);
  }
}

/** parseNodes on `text`: the bases and the warnings it gave. */
function parse(text) {
  const warnings = [];
  const bases = parseNodes(text, (message) => warnings.push(message));
  return { bases, warnings };
}

const page = { protocol: "http:", host: "page.example:8480", search: "" };

// Parsing.
{
  const { bases, warnings } = parse("http://127.0.0.1:8481,http://127.0.0.1:8482");
  same(bases, ["http://127.0.0.1:8481", "http://127.0.0.1:8482"], "valid list");
  same(warnings.length, 0, "valid list warnings");
}
{
  const { bases, warnings } = parse(" http://a:1/ ,,https://b.example//, ,http://c:3/prefix/");
  same(bases, ["http://a:1", "https://b.example", "http://c:3/prefix"], "blanks and trailing slashes");
  same(warnings.length, 0, "blanks and trailing slashes warnings");
}
{
  const bad = ["ftp://a:1", "ws://a:2", "127.0.0.1:8481", "javascript:alert(1)", "http://a:1/?x=1", "http://a:1/#x", "http://u:p@a:1", "not a url", "http://"];
  const { bases, warnings } = parse(["http://ok:1", ...bad, "https://ok:2"].join(","));
  same(bases, ["http://ok:1", "https://ok:2"], "bad entries dropped");
  same(warnings.length, bad.length, "one warning per bad entry");
  bad.forEach((entry, i) => {
    if (!warnings[i]?.includes(entry)) {
      failures.push(`warning ${i}: ${JSON.stringify(warnings[i])} does not name ${JSON.stringify(entry)}`);
    }
  });
}
same(parse("http://a:1,http://a:1/").bases, ["http://a:1"], "duplicates count once");
same(parse("HTTP://A.Example:80/").bases, ["http://a.example"], "scheme and host normalised");
same(parse("").bases, [], "empty text");
same(parse(null).bases, [], "no parameter");

// From the page's location.
{
  const warnings = [];
  const nodes = Nodes.fromLocation({ ...page, search: "?head=scan&nodes=http://127.0.0.1:8481,https://n2.example:8482/" }, (m) => warnings.push(m));
  same(nodes.bases, ["http://127.0.0.1:8481", "https://n2.example:8482"], "fromLocation list");
  same(nodes.listed, true, "fromLocation listed");
  same(warnings.length, 0, "fromLocation warnings");
}
{
  const warnings = [];
  const nodes = Nodes.fromLocation({ ...page, search: "?nodes=ftp://x" }, (m) => warnings.push(m));
  same(nodes.listed, false, "nothing usable: the origin");
  same(warnings.length, 2, "nothing usable: the entry's warning and the fallback's");
}

// The page's own origin (no list): relative HTTP URLs, the page's host for sockets.
{
  const origin = Nodes.fromLocation({ ...page, search: "?head=scan" }, () => failures.push("origin: warned"));
  same(origin.listed, false, "origin listed");
  same(origin.size, 1, "origin size");
  same(origin.label(), null, "origin label");
  same(origin.httpUrl("/v1/heads"), "/v1/heads", "origin httpUrl");
  same(origin.wsUrl("/v1/heads/scan/streams/main/view?algo=T"), "ws://page.example:8480/v1/heads/scan/streams/main/view?algo=T", "origin wsUrl");
  same(origin.advance(), 0, "origin advance stays");
  const secure = new Nodes([], { protocol: "https:", host: "page.example" });
  same(secure.wsUrl("/x"), "wss://page.example/x", "https origin wsUrl");
}

// A list: URLs on the current node, ws for http and wss for https, round robin.
{
  const nodes = new Nodes(parse("http://127.0.0.1:8481,https://n2.example:8482/,http://n3:8483/base/").bases, page);
  same(nodes.size, 3, "size");
  same(nodes.label(), "127.0.0.1:8481", "label 0");
  same(nodes.httpUrl("/v1/heads"), "http://127.0.0.1:8481/v1/heads", "httpUrl 0");
  same(nodes.wsUrl("/v1/heads/a/streams/main/view?algo=T"), "ws://127.0.0.1:8481/v1/heads/a/streams/main/view?algo=T", "wsUrl 0");
  same(nodes.httpUrl("http://other:1/mesh.bin"), "http://other:1/mesh.bin", "a full URL stays");
  same(nodes.advance(), 1, "advance to 1");
  same(nodes.label(), "n2.example:8482", "label 1");
  same(nodes.httpUrl("/v1/heads/a/mesh.bin"), "https://n2.example:8482/v1/heads/a/mesh.bin", "httpUrl 1");
  same(nodes.wsUrl("/v1/heads/a/streams/main/view"), "wss://n2.example:8482/v1/heads/a/streams/main/view", "https -> wss");
  same(nodes.advance(), 2, "advance to 2");
  same(nodes.httpUrl("/v1/algorithms"), "http://n3:8483/base/v1/algorithms", "httpUrl with a path prefix");
  same(nodes.wsUrl("/v"), "ws://n3:8483/base/v", "wsUrl with a path prefix");
  same(nodes.advance(), 0, "advance wraps to 0");
  // Two views lose node 0 together: the second one's advance finds 1 current and stays.
  same(nodes.advance(0), 1, "first loser moves on");
  same(nodes.advance(0), 1, "second loser does not skip node 1");
  same(nodes.label(0), "127.0.0.1:8481", "label of a given node");
}

// Fetch failover: a network error (TypeError) moves on, once per remaining node.
{
  const nodes = new Nodes(parse("http://a:1,http://b:2,http://c:3").bases, page);
  const asked = [];
  const down = new Set(["http://a:1", "http://b:2"]);
  const fakeFetch = async (url) => {
    asked.push(url);
    if ([...down].some((base) => url.startsWith(base))) {
      throw new TypeError("Failed to fetch");
    }
    return { ok: true, url };
  };
  const response = await nodes.fetch("/v1/heads", undefined, fakeFetch);
  same(response.url, "http://c:3/v1/heads", "fetch reaches the node that answers");
  same(asked, ["http://a:1/v1/heads", "http://b:2/v1/heads", "http://c:3/v1/heads"], "fetch tries in order");
  same(nodes.index, 2, "fetch leaves the answering node current");

  down.add("http://c:3");
  asked.length = 0;
  try {
    await nodes.fetch("/v1/heads", undefined, fakeFetch);
    failures.push("fetch with every node down: no error");
  } catch (error) {
    same(error instanceof TypeError, true, "fetch with every node down throws the network error");
  }
  same(asked, ["http://c:3/v1/heads", "http://a:1/v1/heads", "http://b:2/v1/heads"], "every node tried once");

  asked.length = 0;
  const refusing = async (url) => {
    asked.push(url);
    throw new Error("not a network error");
  };
  try {
    await nodes.fetch("/v1/heads", undefined, refusing);
    failures.push("other errors: no error");
  } catch (error) {
    same(error.message, "not a network error", "other errors pass through");
  }
  same(asked.length, 1, "other errors are not retried");
}

if (failures.length > 0) {
  console.error(`${failures.length} mismatch(es):\n${failures.join("\n")}`);
  process.exit(1);
}
console.log("nodes.js parses the node list, builds the URLs and fails over round robin");
