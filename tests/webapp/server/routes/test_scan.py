"""The photo fallback: ``/scan`` decodes an uploaded photo and opens our codes only."""

import io
from collections.abc import Callable, Iterator
from typing import Any

import httpx
import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient
from PIL import Image

from tag_service.codes import (
    Contact,
    make_symbol,
    render_png,
    tel_payload,
    text_payload,
    url_payload,
    vcard_payload,
)
from tag_service.sizing import min_module_mm
from tag_service.verify import Shot, phone_frame
from tests.conftest import migrate, services_of
from webapp.core.settings import Settings
from webapp.server.app import create_app
from webapp.server.routes import scan
from webapp.tags.registry import wall_tags

BASE_URL = "http://192.168.1.20:8000"
CODE = "K7Q2ZP9"
NO_CODE_MESSAGE = "No code found in the photo; hold the phone steady, fill the frame"


def png_of(payload: str, scale: int = 6) -> bytes:
    return render_png(make_symbol(payload), scale)


def jpeg_of(image: Image.Image) -> bytes:
    buffer = io.BytesIO()
    image.convert("RGB").save(buffer, "JPEG", quality=85)
    return buffer.getvalue()


def post_photo(
    client: TestClient, data: bytes, name: str = "photo.png", kind: str = "image/png"
) -> httpx.Response:
    return client.post("/scan", files={"photo": (name, data, kind)}, follow_redirects=False)


def assert_no_traceback(response: httpx.Response) -> None:
    for leak in ("Traceback", 'File "', "Error(", "site-packages"):
        assert leak not in response.text


def test_the_form_opens_the_back_camera(client: TestClient) -> None:
    response = client.get("/scan")
    assert response.status_code == 200
    page = response.text
    assert 'method="post"' in page and 'action="/scan"' in page
    assert 'enctype="multipart/form-data"' in page
    assert 'type="file"' in page and 'name="photo"' in page
    assert 'accept="image/*"' in page and 'capture="environment"' in page and "required" in page
    assert "Take a photo of the code" in page
    assert "<script" not in page and "style=" not in page  # the CSP allows neither inline


def test_a_photo_of_our_code_redirects_to_it(client: TestClient) -> None:
    response = post_photo(client, png_of(url_payload(BASE_URL, CODE)))
    assert response.status_code == 303
    assert response.headers["location"] == f"/t/{CODE}"


@pytest.mark.parametrize(
    "payload",
    [
        f"http://192.168.1.20:8000/t/{CODE.lower()}",  # lower-case path and code
        f"HTTPS://WALL.EXAMPLE.ORG/T/{CODE}",  # the server under another name
        f"http://10.0.0.7/T/{CODE}?utm=x",  # query strings do not matter
    ],
)
def test_any_host_and_case_still_goes_to_our_own_page(client: TestClient, payload: str) -> None:
    response = post_photo(client, png_of(payload))
    assert response.status_code == 303
    assert response.headers["location"] == f"/t/{CODE}"  # relative: never another host


def test_a_photo_like_jpeg_still_works(client: TestClient) -> None:
    """The code as a phone at the design distance sees it: a full, tilted, noisy frame."""
    code = Image.open(io.BytesIO(png_of(url_payload(BASE_URL, CODE), 4)))
    shot = Shot(distance_m=2.0, tilt_deg=20, roll_deg=5, aim_mm=(60.0, 20.0))
    frame = phone_frame(code, min_module_mm(2.0) / 4, (code.width / 2, code.height / 2), shot)
    response = post_photo(client, jpeg_of(frame), "IMG_0042.jpg", "image/jpeg")
    assert response.status_code == 303
    assert response.headers["location"] == f"/t/{CODE}"


def test_decoding_runs_in_the_thread_pool(
    client: TestClient, monkeypatch: pytest.MonkeyPatch
) -> None:
    ran: list[str] = []
    real = scan.run_blocking

    async def recording(func: Callable[..., Any], *args: Any) -> Any:
        ran.append(func.__name__)
        return await real(func, *args)

    monkeypatch.setattr(scan, "run_blocking", recording)
    assert post_photo(client, png_of(url_payload(BASE_URL, CODE))).status_code == 303
    assert ran == ["_decode", "_described"]


def test_a_foreign_url_is_shown_but_not_linked(client: TestClient) -> None:
    url = "https://example.com/promo?a=1&b=2"
    response = post_photo(client, png_of(url))
    assert response.status_code == 200
    assert "https://example.com/promo?a=1&amp;b=2" in response.text
    assert 'href="https://example.com' not in response.text
    assert "not one of this wall" in response.text


def test_a_foreign_url_with_a_broken_code_is_not_ours(client: TestClient) -> None:
    response = post_photo(client, png_of("https://example.com/T/NOT-A-CODE"))
    assert response.status_code == 200
    assert "https://example.com/T/NOT-A-CODE" in response.text
    assert "/t/" not in response.text.lower().replace("https://example.com/t/", "")


def test_text_is_shown_escaped(client: TestClient) -> None:
    text = text_payload("<script>alert('owned')</script> Room 2.14 & more")
    response = post_photo(client, png_of(text))
    assert response.status_code == 200
    assert "&lt;script&gt;alert(" in response.text
    assert "Room 2.14 &amp; more" in response.text
    assert "<script" not in response.text


def test_a_phone_number_gets_a_tel_link(client: TestClient) -> None:
    response = post_photo(client, png_of(tel_payload("+49 (30) 1234-5678")))
    assert response.status_code == 200
    assert 'href="tel:+493012345678"' in response.text


def test_a_tel_payload_that_is_not_a_number_is_only_text(client: TestClient) -> None:
    response = post_photo(client, png_of('tel:123" onclick="x'))
    assert response.status_code == 200
    assert 'href="tel:' not in response.text
    assert "tel:123&#34; onclick=&#34;x" in response.text


def test_a_contact_card_is_shown_preformatted(client: TestClient) -> None:
    card = vcard_payload(Contact("Ada Lovelace", phone="+44 20 7946 0000"))
    response = post_photo(client, png_of(card))
    assert response.status_code == 200
    assert '<pre class="payload">BEGIN:VCARD' in response.text
    assert "Ada Lovelace" in response.text


def sheet(*payloads: str) -> bytes:
    """One picture holding several codes side by side."""
    codes = [Image.open(io.BytesIO(png_of(p, 4))).convert("L") for p in payloads]
    picture = Image.new("L", (sum(c.width for c in codes), max(c.height for c in codes)), 255)
    x = 0
    for code in codes:
        picture.paste(code, (x, 0))
        x += code.width
    buffer = io.BytesIO()
    picture.save(buffer, "PNG")
    return buffer.getvalue()


def test_one_of_ours_among_others_redirects_to_ours(client: TestClient) -> None:
    photo = sheet("just some text", url_payload(BASE_URL, CODE), url_payload(BASE_URL, CODE))
    response = post_photo(client, photo)
    assert response.status_code == 303
    assert response.headers["location"] == f"/t/{CODE}"


def test_the_code_nearest_the_middle_of_the_photo_is_opened(client: TestClient) -> None:
    photo = sheet(url_payload(BASE_URL, CODE), url_payload(BASE_URL, "ABC1234"), "hello")
    response = post_photo(client, photo)  # ABC1234 is in the middle, the others beside it
    assert response.status_code == 303
    assert response.headers["location"] == "/t/ABC1234"


def registration_codes(client: TestClient) -> dict[str, str]:
    tags = wall_tags(services_of(client).db, "demo")
    return {t.label: t.code for t in tags if t.app == "core"}


def test_codes_equally_near_the_middle_are_offered_by_what_they_mark(client: TestClient) -> None:
    codes = registration_codes(client)
    photo = sheet(
        url_payload(BASE_URL, codes["Student"]), url_payload(BASE_URL, codes["Instructor"])
    )
    response = post_photo(client, photo)
    assert response.status_code == 200, "two codes, neither clearly aimed at: ask"
    page = response.text
    assert "Which code did you mean?" in page
    assert f'href="/t/{codes["Student"]}">Open Student</a>' in page
    assert f'href="/t/{codes["Instructor"]}">Open Instructor</a>' in page
    assert page.count("on display r2c1, Demo wall (3 x 2, 55-inch)") == 2


def test_a_lone_code_off_to_the_side_is_offered_not_followed(client: TestClient) -> None:
    """A neighbour's code caught at the edge of a photo aimed at something else."""
    codes = registration_codes(client)
    code = Image.open(io.BytesIO(png_of(url_payload(BASE_URL, codes["Student"]), 4)))
    photo = Image.new("L", (1600, 1200), 255)
    photo.paste(code.convert("L"), (1600 - code.width, 0))
    response = post_photo(client, jpeg_of(photo), "IMG_0044.jpg", "image/jpeg")
    assert response.status_code == 200
    assert "Which code did you mean?" in response.text
    assert "a code off to the side of the photo" in response.text
    assert f'href="/t/{codes["Student"]}">Open Student</a>' in response.text


def test_a_photo_without_a_code_shows_the_form_again(client: TestClient) -> None:
    blank = Image.new("RGB", (800, 600), (200, 190, 180))
    response = post_photo(client, jpeg_of(blank), "IMG_0043.jpg", "image/jpeg")
    assert response.status_code == 422
    assert NO_CODE_MESSAGE in response.text
    assert 'capture="environment"' in response.text
    assert_no_traceback(response)


@pytest.mark.parametrize(
    "data",
    [
        b"MZ\x90\x00 definitely not a picture" * 10,
        png_of("cut short")[:200],
        b"%!PS-Adobe-3.0 EPSF-3.0\n%%BoundingBox: 0 0 10 10\n",
    ],
)
def test_a_file_that_is_not_a_picture_gets_a_415(client: TestClient, data: bytes) -> None:
    response = post_photo(client, data, "notes.pdf", "application/pdf")
    assert response.status_code == 415
    assert "That file is not a picture we can read" in response.text
    assert_no_traceback(response)


def test_a_picture_with_too_many_pixels_gets_a_413(client: TestClient) -> None:
    """A small file claiming 8000 x 8000 pixels (64 MP) is refused before decoding."""
    huge = Image.new("1", (8_000, 8_000), 1)
    buffer = io.BytesIO()
    huge.save(buffer, "PNG", optimize=True)
    assert len(buffer.getvalue()) < 1_000_000
    response = post_photo(client, buffer.getvalue())
    assert response.status_code == 413
    assert "too many pixels" in response.text and "at most 40 million pixels" in response.text
    assert_no_traceback(response)


def test_an_empty_upload_gets_a_clear_400(client: TestClient) -> None:
    response = post_photo(client, b"", "empty.jpg", "image/jpeg")
    assert response.status_code == 400
    assert "The photo was empty" in response.text
    assert_no_traceback(response)


def test_no_file_chosen_gets_a_clear_400(client: TestClient) -> None:
    """What a browser sends when no file was chosen (were ``required`` bypassed)."""
    body = (
        b"--b0undary\r\n"
        b'Content-Disposition: form-data; name="photo"; filename=""\r\n'
        b"Content-Type: application/octet-stream\r\n\r\n"
        b"\r\n--b0undary--\r\n"
    )
    response = client.post(
        "/scan",
        content=body,
        headers={"content-type": "multipart/form-data; boundary=b0undary"},
        follow_redirects=False,
    )
    assert response.status_code == 400
    assert "The photo was empty" in response.text


@pytest.mark.parametrize(
    "request_kwargs",
    [
        {},
        {"data": {"photo": "not a file"}},
        {"files": {"picture": ("p.png", b"\x89PNG", "image/png")}},
        {"content": b"--x\r\nnonsense", "headers": {"content-type": "multipart/form-data"}},
    ],
    ids=["no-body", "text-field", "other-field", "malformed-multipart"],
)
def test_a_missing_photo_gets_a_400(client: TestClient, request_kwargs: dict[str, Any]) -> None:
    response = client.post("/scan", follow_redirects=False, **request_kwargs)
    assert response.status_code == 400
    assert "take or choose a photo" in response.text
    assert_no_traceback(response)


@pytest.fixture
def small_app(settings: Settings) -> FastAPI:
    """An app that accepts photos of at most 20 000 bytes."""
    small = settings.model_copy(update={"scan_upload_max_bytes": 20_000})
    migrate(small.resolved_database_url)
    return create_app(small)


@pytest.fixture
def small_client(small_app: FastAPI) -> Iterator[TestClient]:
    with TestClient(small_app) as test_client:
        yield test_client


@pytest.mark.parametrize("size", [20_001, 30_000, 500_000])
def test_an_oversize_photo_gets_a_413(small_client: TestClient, size: int) -> None:
    """Just over the limit (counted while reading) and far over it (Content-Length)."""
    response = post_photo(small_client, b"\xff" * size, "big.jpg", "image/jpeg")
    assert response.status_code == 413
    assert "The photo is larger than 0.02 MB" in response.text
    assert_no_traceback(response)


def test_a_photo_at_the_limit_is_read(small_client: TestClient) -> None:
    photo = png_of(url_payload(BASE_URL, CODE), 4)
    photo += b"\0" * (20_000 - len(photo))  # trailing bytes after IEND are ignored
    assert len(photo) == 20_000
    response = post_photo(small_client, photo)
    assert response.status_code == 303


def test_a_chunked_upload_without_length_is_cut_off(small_client: TestClient) -> None:
    boundary = "tagwallboundary"
    head = (
        f"--{boundary}\r\nContent-Disposition: form-data; name=photo; filename=a.jpg\r\n"
        "Content-Type: image/jpeg\r\n\r\n"
    ).encode()

    def body() -> Iterator[bytes]:
        yield head
        for _ in range(100):
            yield b"\xff" * 10_000
        yield f"\r\n--{boundary}--\r\n".encode()

    response = small_client.post(
        "/scan",
        content=body(),
        headers={"content-type": f"multipart/form-data; boundary={boundary}"},
        follow_redirects=False,
    )
    assert response.status_code == 413
    assert "The photo is larger than 0.02 MB" in response.text


async def test_a_declared_oversize_body_is_refused_before_it_is_read(small_app: FastAPI) -> None:
    sent: list[dict[str, Any]] = []

    async def receive() -> dict[str, Any]:
        raise AssertionError("the body was read")

    async def send(message: dict[str, Any]) -> None:
        sent.append(message)

    scope = {
        "type": "http",
        "asgi": {"version": "3.0"},
        "http_version": "1.1",
        "method": "POST",
        "scheme": "http",
        "path": "/scan",
        "raw_path": b"/scan",
        "root_path": "",
        "query_string": b"",
        "headers": [
            (b"host", b"testserver"),
            (b"content-type", b"multipart/form-data; boundary=x"),
            (b"content-length", b"50000000"),
        ],
        "client": ("127.0.0.1", 50000),
        "server": ("testserver", 80),
    }
    await small_app(scope, receive, send)
    assert sent[0]["status"] == 413
    page = b"".join(m.get("body", b"") for m in sent[1:]).decode()
    assert "The photo is larger than 0.02 MB" in page


@pytest.mark.parametrize(
    ("payload", "kind", "href"),
    [
        (f"http://192.168.1.20:8000/T/{CODE}", "ours", f"/t/{CODE}"),
        (f"https://wall.example/t/{CODE.lower()}", "ours", f"/t/{CODE}"),
        (f"ftp://wall.example/T/{CODE}", "url", None),
        (f"/T/{CODE}", "text", None),
        (f"http://wall.example/x/T/{CODE}", "url", None),
        ("http://wall.example/T/ABC12345", "url", None),
        ("http://[::1/T/ABC1234", "text", None),
        ("TEL:+4930123", "tel", "tel:+4930123"),
        ("tel:javascript:alert(1)", "text", None),
        ("begin:vcard\nFN:Ada\nend:vcard", "vcard", None),
        ("mailto:ada@example.org", "text", None),
    ],
)
def test_classify(payload: str, kind: str, href: str | None) -> None:
    found = scan.classify(payload)
    assert (found.kind, found.href) == (kind, href)
