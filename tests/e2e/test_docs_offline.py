"""/docs works without internet (issue 16.10): every request that leaves the
server is aborted, and Swagger UI still draws the API's operations."""

from __future__ import annotations


def _offline(page, server) -> list[str]:
    """Abort anything not served by `server`; returns the URLs that tried to leave."""
    outside: list[str] = []

    def route(r):
        if r.request.url.startswith(server.url):
            r.continue_()
        else:
            outside.append(r.request.url)
            r.abort()

    page.route("**/*", route)
    return outside


def test_swagger_ui_draws_every_operation_offline(new_page, server):
    page = new_page()
    outside = _offline(page, server)
    page.goto(f"{server.url}/docs")
    page.wait_for_selector(".opblock", timeout=30_000)
    summaries = page.locator(".opblock-summary-path").all_inner_texts()
    assert "/api/jobs" in [s.replace("\u200b", "") for s in summaries], summaries
    assert page.locator(".swagger-ui .info .title").inner_text().startswith("gaitmend")
    assert outside == [], outside
