import stat
from pathlib import Path
from typing import Any

import pytest
from pydantic import ValidationError

from webapp.core.settings import CONTENT_DIR, Settings, lan_address


def test_defaults_are_embedded(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.chdir(tmp_path)
    settings = Settings()
    assert settings.resolved_database_url == "sqlite:///var/tagwall.db"
    assert settings.host == "0.0.0.0" and settings.port == 8000  # phones must get in
    assert settings.bus == "memory"


def test_environment_prefix(monkeypatch: pytest.MonkeyPatch) -> None:
    monkeypatch.setenv("TAGWALL_PORT", "9123")
    monkeypatch.setenv("TAGWALL_HOST", "0.0.0.0")
    monkeypatch.setenv("TAGWALL_WALL_CONFIGS", "a.toml:walls")
    settings = Settings()
    assert settings.port == 9123
    assert settings.wall_configs == [Path("a.toml"), Path("walls")]
    assert settings.server_url.endswith(":9123")
    assert "0.0.0.0" not in settings.server_url


def test_each_subfolder_of_the_content_folder_falls_back_on_the_shipped_one(
    tmp_path: Path,
) -> None:
    """Issue 30: an installation brings only the content it changes; ``serve`` says
    what it takes from the checkout instead."""
    (tmp_path / "brain_atlas").mkdir()
    settings = Settings(content_dir=tmp_path)
    assert settings.content_folder("brain_atlas") == tmp_path / "brain_atlas"
    assert settings.content_folder("census") == CONTENT_DIR / "census"
    assert settings.content_folder("hello") == tmp_path / "hello"  # nothing to fall back on
    assert settings.resolved_wall_configs == [CONTENT_DIR / "walls"]
    assert settings.content_fallbacks() == [
        f"content: {tmp_path} has no {name}/; using the shipped {CONTENT_DIR / name}"
        for name in ("census", "walls")
    ]
    (tmp_path / "walls").mkdir()
    assert Settings(content_dir=tmp_path).resolved_wall_configs == [tmp_path / "walls"]
    configured = Settings(content_dir=tmp_path, wall_configs=[Path("a.toml")])
    assert configured.resolved_wall_configs == [Path("a.toml")]
    shipped = Settings()
    assert shipped.content_dir == CONTENT_DIR and shipped.content_fallbacks() == []


def test_a_content_folder_that_is_not_there_is_refused(tmp_path: Path) -> None:
    with pytest.raises(ValidationError, match="is not a folder"):
        Settings(content_dir=tmp_path / "nowhere")


def test_secret_is_generated_once_and_private(tmp_path: Path) -> None:
    first = Settings(var_dir=tmp_path).resolved_secret_key
    second = Settings(var_dir=tmp_path).resolved_secret_key
    assert first == second and len(first) >= 32
    mode = (tmp_path / "secret_key").stat().st_mode
    assert stat.S_IMODE(mode) == 0o600


@pytest.mark.parametrize("secret", ["changeme", "secret", "tagwall", "short"])
def test_known_or_weak_secret_refused_outside_dev(secret: str) -> None:
    with pytest.raises(ValidationError, match="TAGWALL_SECRET_KEY"):
        Settings(env="production", secret_key=secret)


def test_known_secret_allowed_in_dev() -> None:
    assert Settings(env="dev", secret_key="changeme").resolved_secret_key == "changeme"


def test_codes_point_where_the_server_listens() -> None:
    everywhere = Settings(port=8123)
    assert everywhere.resolved_public_base_url == f"http://{lan_address()}:8123"
    assert everywhere.local_url == "http://127.0.0.1:8123"
    local = Settings(host="127.0.0.1", port=8123)
    assert local.resolved_public_base_url == local.local_url == "http://127.0.0.1:8123"
    one = Settings(host="10.1.2.3", port=8123)
    assert one.resolved_public_base_url == one.local_url == "http://10.1.2.3:8123"
    explicit = Settings(public_base_url="http://wall.example.org/")
    assert explicit.resolved_public_base_url == "http://wall.example.org"


def test_lan_address_is_ipv4() -> None:
    parts = lan_address().split(".")
    assert len(parts) == 4 and all(0 <= int(p) <= 255 for p in parts)


def test_invalid_values_are_rejected() -> None:
    with pytest.raises(ValidationError):
        Settings(port=0)
    with pytest.raises(ValidationError):
        Settings(bus="carrier-pigeon")  # type: ignore[arg-type]


def test_pubmed_settings_defaults_and_environment(monkeypatch: pytest.MonkeyPatch) -> None:
    settings = Settings()
    assert settings.pubmed_url == "https://eutils.ncbi.nlm.nih.gov/entrez/eutils/"
    assert settings.pubmed_timeout == 5.0 and settings.pubmed_results == 8
    assert settings.pubmed_cache_seconds == 86_400 and settings.pubmed_email is None
    monkeypatch.setenv("TAGWALL_PUBMED_EMAIL", "atlas@example.org")
    monkeypatch.setenv("TAGWALL_PUBMED_TIMEOUT", "2.5")
    monkeypatch.setenv("TAGWALL_PUBMED_CACHE_SECONDS", "0")
    settings = Settings()
    assert settings.pubmed_email == "atlas@example.org"
    assert settings.pubmed_timeout == 2.5 and settings.pubmed_cache_seconds == 0


@pytest.mark.parametrize(
    "field,value",
    [
        ("pubmed_timeout", 0),
        ("pubmed_timeout", 60.5),
        ("pubmed_results", 0),
        ("pubmed_results", 51),
        ("pubmed_cache_seconds", -1),
        ("pubmed_url", "eutils.ncbi.nlm.nih.gov/entrez/eutils/"),
    ],
)
def test_pubmed_settings_out_of_bounds_are_rejected(field: str, value: Any) -> None:
    with pytest.raises(ValidationError, match=field):
        Settings(**{field: value})


def test_production_needs_a_secret_key() -> None:
    with pytest.raises(ValidationError, match="TAGWALL_SECRET_KEY is required in production"):
        Settings(env="production", secret_key="")
    assert Settings(env="production", secret_key="s" * 32).resolved_secret_key == "s" * 32


def test_several_workers_need_redis_and_postgresql() -> None:
    assert Settings().workers == 1
    with pytest.raises(ValidationError, match="needs TAGWALL_BUS=redis"):
        Settings(workers=2)
    with pytest.raises(ValidationError, match="needs PostgreSQL"):
        Settings(workers=2, bus="redis", database_url="sqlite:///var/x.db")
    shared = Settings(workers=2, bus="redis", database_url="postgresql+psycopg://db/tagwall")
    assert shared.workers == 2
