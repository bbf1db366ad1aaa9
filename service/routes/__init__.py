"""HTTP routes: thin. Parse the request, call one service function, answer with what it returns."""
