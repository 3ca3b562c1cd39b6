// socket-worker.js: the worker a view's socket runs in (socket-thread.js starts it): one
// SocketPump (socket-pump.js) taking the page's requests and posting back what arrives.

import { SocketPump } from "./socket-pump.js";

const pump = new SocketPump((event, transfer) => self.postMessage(event, transfer));
self.onmessage = ({ data }) => pump.handle(data);
self.postMessage({ kind: "ready" });
