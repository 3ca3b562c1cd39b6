// app.js: written with the web client
