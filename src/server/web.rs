//! The browser client, embedded in the binary so one command serves everything: a small
//! page that shows a registered head talking live (see `web/`).

use axum::http::header;
use axum::response::IntoResponse;
use axum::routing::get;
use axum::Router;

const HTML: &str = "text/html; charset=utf-8";
const CSS: &str = "text/css; charset=utf-8";
const JS: &str = "text/javascript; charset=utf-8";

/// `(path, content type, body)` of every embedded file. The `web/*.test.mjs` scripts and
/// `web/package.json` are for the tests (`tests/service/web_decode.rs`), not served.
const ASSETS: [(&str, &str, &str); 27] = [
    ("/", HTML, include_str!("../../web/index.html")),
    ("/style.css", CSS, include_str!("../../web/style.css")),
    ("/app.js", JS, include_str!("../../web/app.js")),
    ("/camera.js", JS, include_str!("../../web/camera.js")),
    ("/chart.js", JS, include_str!("../../web/chart.js")),
    ("/codes.js", JS, include_str!("../../web/codes.js")),
    ("/decode.js", JS, include_str!("../../web/decode.js")),
    ("/draw-scale.js", JS, include_str!("../../web/draw-scale.js")),
    (
        "/facewire-head.js",
        JS,
        include_str!("../../web/facewire-head.js"),
    ),
    ("/fit.js", JS, include_str!("../../web/fit.js")),
    ("/head-group.js", JS, include_str!("../../web/head-group.js")),
    ("/head-view.js", JS, include_str!("../../web/head-view.js")),
    ("/nodes.js", JS, include_str!("../../web/nodes.js")),
    ("/panel.js", JS, include_str!("../../web/panel.js")),
    ("/playout.js", JS, include_str!("../../web/playout.js")),
    (
        "/playout-worklet.js",
        JS,
        include_str!("../../web/playout-worklet.js"),
    ),
    ("/quantile.js", JS, include_str!("../../web/quantile.js")),
    ("/render.js", JS, include_str!("../../web/render.js")),
    ("/replay.js", JS, include_str!("../../web/replay.js")),
    ("/socket-pump.js", JS, include_str!("../../web/socket-pump.js")),
    (
        "/socket-thread.js",
        JS,
        include_str!("../../web/socket-thread.js"),
    ),
    (
        "/socket-worker.js",
        JS,
        include_str!("../../web/socket-worker.js"),
    ),
    ("/sound.js", JS, include_str!("../../web/sound.js")),
    ("/stream.js", JS, include_str!("../../web/stream.js")),
    ("/talk.js", JS, include_str!("../../web/talk.js")),
    ("/talk-worklet.js", JS, include_str!("../../web/talk-worklet.js")),
    ("/upload.js", JS, include_str!("../../web/upload.js")),
];

pub fn routes<S: Clone + Send + Sync + 'static>() -> Router<S> {
    let mut router = Router::new();
    for (path, content_type, body) in ASSETS {
        router = router.route(
            path,
            get(move || async move {
                (
                    [
                        (header::CONTENT_TYPE, content_type),
                        (header::CACHE_CONTROL, "no-cache"),
                    ],
                    body,
                )
                    .into_response()
            }),
        );
    }
    router
}

#[cfg(test)]
mod tests {
    use super::ASSETS;
    use facewire_proto::codes::{CloseCode, EndReason};

    /// The modules a served script imports (`from "./x.js"`, `import("./x.js")`, a worklet's
    /// `addModule(new URL("./x.js", ...))`): every one must be served too.
    fn imports(script: &str) -> Vec<String> {
        script
            .split("\"./")
            .skip(1)
            .filter_map(|rest| rest.split_once('"').map(|(name, _)| name))
            .filter(|name| name.ends_with(".js"))
            .map(|name| format!("/{name}"))
            .collect()
    }

    #[test]
    fn every_module_a_served_script_imports_is_served() {
        let served: Vec<&str> = ASSETS.iter().map(|(path, _, _)| *path).collect();
        let mut checked = 0;
        for (path, content_type, body) in ASSETS {
            if content_type != super::JS {
                continue;
            }
            for module in imports(body) {
                assert!(
                    served.contains(&module.as_str()),
                    "{path} imports {module}, which is not served"
                );
                checked += 1;
            }
        }
        assert!(checked > 20, "only {checked} imports found");
        assert_eq!(imports("import { a } from \"./b.js\";"), ["/b.js"]);
    }

    const CODES_JS: &str = include_str!("../../web/codes.js");

    #[test]
    fn the_page_knows_every_close_code_and_end_reason_as_the_protocol_defines_them() {
        for code in CloseCode::ALL {
            let entry = format!("  {}: {},", code.name(), code.code());
            assert!(CODES_JS.contains(&entry), "web/codes.js lacks {entry:?}");
        }
        assert_eq!(
            CODES_JS.matches(": 1").count() + CODES_JS.matches(": 4").count(),
            CloseCode::ALL.len()
        );
        let finals: Vec<String> = CloseCode::ALL
            .iter()
            .filter(|c| c.is_final())
            .map(|c| format!("CLOSE.{}", c.name()))
            .collect();
        let line = CODES_JS
            .lines()
            .find(|l| l.contains("FINAL_CLOSE_CODES ="))
            .unwrap();
        assert_eq!(line.matches("CLOSE.").count(), finals.len(), "{line}");
        for name in finals {
            assert!(line.contains(&name), "{line} lacks {name}");
        }
        for reason in EndReason::ALL {
            assert!(
                CODES_JS.contains(&format!("  {}: \"", reason.as_str())),
                "web/codes.js lacks {reason}"
            );
        }
    }
}
