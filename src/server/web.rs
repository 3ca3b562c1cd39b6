//! The browser client, embedded in the binary so one command serves everything: a small
//! page that shows a registered head talking live (see `web/`).

use axum::http::header;
use axum::response::IntoResponse;
use axum::routing::get;
use axum::Router;

const HTML: &str = "text/html; charset=utf-8";
const CSS: &str = "text/css; charset=utf-8";
const JS: &str = "text/javascript; charset=utf-8";

/// `(path, content type, body)` of every embedded file. `web/decode.test.mjs` and
/// `web/package.json` are for the decoder test (`tests/web_decode.rs`), not served.
const ASSETS: [(&str, &str, &str); 9] = [
    ("/", HTML, include_str!("../../web/index.html")),
    ("/style.css", CSS, include_str!("../../web/style.css")),
    ("/app.js", JS, include_str!("../../web/app.js")),
    ("/camera.js", JS, include_str!("../../web/camera.js")),
    ("/chart.js", JS, include_str!("../../web/chart.js")),
    ("/decode.js", JS, include_str!("../../web/decode.js")),
    ("/panel.js", JS, include_str!("../../web/panel.js")),
    ("/render.js", JS, include_str!("../../web/render.js")),
    ("/stream.js", JS, include_str!("../../web/stream.js")),
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
