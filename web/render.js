// render.js: written with the web client
