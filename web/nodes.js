// nodes.js: the server nodes the page talks to. Several facewire nodes can share one bus,
// and every node serves every head and every stream, so a page given `?nodes=URL,URL`
// fails over by itself: when a node stops answering, the sockets and the fetches move to
// the next one (round robin) instead of waiting for it to come back. Without `nodes` the
// page talks to its own origin only, with relative URLs, as it always did (behind a load
// balancer that is all it needs). No DOM: node tests it (nodes.test.mjs).

/**
 * The `nodes` parameter as base URLs: comma-separated, blanks ignored, each an http(s) URL
 * without query, fragment or credentials, its trailing slashes stripped; anything else is
 * dropped with a `warn(message)`. Duplicates count once. An empty or absent text gives [].
 */
export function parseNodes(text, warn = console.warn) {
  const bases = [];
  for (const entry of (text ?? "").split(",").map((e) => e.trim())) {
    if (!entry) {
      continue;
    }
    const base = baseUrl(entry);
    if (base === null) {
      warn(`nodes: ignoring "${entry}": not an http or https base URL`);
    } else if (!bases.includes(base)) {
      bases.push(base);
    }
  }
  return bases;
}

/** `entry` as a base URL (`http://host:port` or with a path prefix), or null. */
function baseUrl(entry) {
  let url;
  try {
    url = new URL(entry);
  } catch {
    return null;
  }
  if ((url.protocol !== "http:" && url.protocol !== "https:") || url.search || url.hash) {
    return null;
  }
  if (url.username || url.password || !url.host) {
    return null;
  }
  return `${url.origin}${url.pathname}`.replace(/\/+$/, "");
}

/** A path the server gave as a full URL already (`http://...`) is used as it is. */
const ABSOLUTE = /^[a-z][a-z0-9+.-]*:/i;

export class Nodes {
  /**
   * `bases`: parseNodes' list; empty means the page's own origin, `page` ({ protocol,
   * host }, as `location`), reached with relative URLs.
   */
  constructor(bases, page) {
    this.bases = [...bases];
    this.page = page;
    this.index = 0;
  }

  /** The nodes from the page's `?nodes=` (`location`-like `page`); none: the origin. */
  static fromLocation(page, warn = console.warn) {
    const params = new URLSearchParams(page.search);
    const bases = parseNodes(params.get("nodes"), warn);
    if (bases.length === 0 && params.has("nodes")) {
      warn("nodes: no usable node in the list; using the page's own origin");
    }
    return new Nodes(bases, page);
  }

  /** True when a list was given (the status line then names the node). */
  get listed() {
    return this.bases.length > 0;
  }

  /** How many nodes there are to try: 1 for the page's origin. */
  get size() {
    return Math.max(1, this.bases.length);
  }

  /** The current node as the status line names it (`127.0.0.1:8482`), null without a list. */
  label(index = this.index) {
    return this.listed ? this.bases[index].replace(/^https?:\/\//, "") : null;
  }

  /** `path` (`/v1/heads`) on the current node; without a list, `path` itself. */
  httpUrl(path) {
    if (!this.listed || ABSOLUTE.test(path)) {
      return path;
    }
    return `${this.bases[this.index]}${path}`;
  }

  /** `path` on the current node as a WebSocket URL: wss for https, ws for http. */
  wsUrl(path) {
    if (!this.listed) {
      const scheme = this.page.protocol === "https:" ? "wss" : "ws";
      return `${scheme}://${this.page.host}${path}`;
    }
    return `ws${this.bases[this.index].slice("http".length)}${path}`;
  }

  /**
   * Moves on from node `from` (the one that failed; by default the current one) to the
   * next, round robin, and returns the current index. When the current node is no longer
   * `from`, someone else (another view, another fetch) has moved on already and this
   * stays where it is, so two views losing the same node do not skip the next one.
   */
  advance(from = this.index) {
    if (from === this.index) {
      this.index = (this.index + 1) % this.size;
    }
    return this.index;
  }

  /**
   * `fetch(path, init)` on the current node; a network error (fetch's TypeError: the node
   * is down or unreachable) moves to the next node and tries again, once per remaining
   * node, then throws the last error. HTTP error statuses are answers and are returned.
   * `fetchFn` is for tests.
   */
  async fetch(path, init, fetchFn = globalThis.fetch) {
    let lastError;
    for (let tries = 0; tries < this.size; tries++) {
      const used = this.index;
      try {
        return await fetchFn(this.httpUrl(path), init);
      } catch (error) {
        if (!(error instanceof TypeError)) {
          throw error;
        }
        lastError = error;
        this.advance(used);
      }
    }
    throw lastError;
  }
}
