"""The server's settings: one ``Settings`` object, read from ``HOMEBOT_*`` environment variables."""

from __future__ import annotations

from functools import lru_cache
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Literal

from pydantic import Field, field_validator, model_validator
from pydantic_settings import BaseSettings, NoDecode, SettingsConfigDict

if TYPE_CHECKING:
    from slam_core.rbpf.config import RBPFConfig
    from slam_core.robot_config import RobotConfig

Mode = Literal["mapping", "localization", "ekf"]

#: Every setting is also the environment variable of its name in capitals after this prefix.
ENV_PREFIX = "HOMEBOT_"

#: Worlds the simulator ships (``homebot serve --world``).
WORLDS = ("flat", "house")


class Settings(BaseSettings):
    """Everything ``homebot serve`` can be told; defaults run the simulated robot locally."""

    model_config = SettingsConfigDict(env_prefix=ENV_PREFIX, extra="ignore", hide_input_in_errors=True)

    host: str = "127.0.0.1"
    port: int = Field(8000, ge=0, le=65535)
    data_dir: Path = Path("./data")
    world: str = "flat"
    #: The robot's description (``homebot serve --robot``); ``None``: the simulated robot's shipped file.
    robot: Path | None = None
    simulation: bool = True
    #: Simulation only: drive the world's scripted tour until someone gives the robot a goal,
    #: steers it or cancels, so that a first visitor sees the home being mapped.
    sim_tour: bool = True
    serial_port: str = "/dev/ttyUSB0"
    serial_baud: int = Field(115200, gt=0)
    #: Real robot only: ``module:callable`` returning an iterator of :class:`slam_core.scan.Scan`.
    sensor_source: str | None = None
    mode: Mode = "mapping"
    seed: int = 0
    #: Replay this CARMEN log (a bundled name or a path) through the live path instead of a robot.
    replay: str | None = None
    #: Speed-up over the log's own timing; ``None``: as fast as the worker steps, dropping no scan.
    replay_speed: float | None = Field(1.0, gt=0.0)
    #: Stop the server once the replay's final optimisation is written.
    replay_exit_at_end: bool = False
    #: The SLAM settings file ``homebot slam --config`` takes (an earlier run's ``config.json``);
    #: ``None``: the SLAM defaults (:class:`slam_core.rbpf.config.RBPFConfig`), as ``homebot slam``'s.
    slam_config: Path | None = None
    #: Continue this saved mapping session on start (``DATA/sessions/NAME.session.npz``).
    resume_session: str | None = None

    cors_origins: Annotated[list[str], NoDecode] = Field(default_factory=list)
    #: The reverse proxy's addresses (comma-separated IPs or networks): only its ``X-Forwarded-Proto``
    #: and ``X-Forwarded-For`` count (https: a ``Secure`` cookie; the client whose logins are limited).
    forwarded_allow_ips: str = "127.0.0.1"
    max_body_bytes: int = Field(64 * 1024, ge=1024)
    token: str | None = Field(None, min_length=32)

    stream_hz: float = Field(15.0, ge=10.0, le=60.0)
    map_hz: float = Field(2.0, ge=1.0, le=10.0)
    status_hz: float = Field(1.0, gt=0.0, le=10.0)
    client_send_timeout_s: float = Field(10.0, gt=0.0)
    max_particles_streamed: int = Field(300, ge=1)

    tile_size: int = 64
    #: Cells of the shared map block: 8192 x 8192 (a 409 m square at 5 cm) fits a campus; the block's pages
    #: are only allocated where the map is written, so a flat costs what it covers.
    map_capacity_cells: int = Field(8192 * 8192, ge=64 * 64)
    mcl_min_particles: int = Field(300, ge=10)
    mcl_max_particles: int = Field(3000, ge=10)
    checkpoint_s: float = Field(1.0, gt=0.0)
    worker_restart_delay_s: float = Field(0.5, ge=0.0)

    control_hz: float = Field(10.0, ge=1.0, le=100.0)
    replan_s: float = Field(2.0, gt=0.0)
    goal_tolerance: float = Field(0.05, gt=0.0, le=1.0)
    #: A robot whose path left does not shrink for this long (s) backs off and replans.
    stuck_after_s: float = Field(8.0, gt=0.0)
    max_speed: float = Field(0.4, gt=0.0)
    max_turn_rate: float = Field(1.2, gt=0.0)
    teleop_hold_s: float = Field(0.5, gt=0.0)

    #: MQTT and Home Assistant discovery (``app/smarthome``): off unless ``mqtt_host`` is set.
    mqtt_host: str | None = None
    mqtt_port: int = Field(1883, ge=1, le=65535)
    mqtt_tls: bool = False
    mqtt_ca_file: Path | None = None
    mqtt_username: str | None = None
    mqtt_password: str | None = None
    mqtt_prefix: str = Field("homebot", pattern=r"^[A-Za-z0-9_\-/]+$")
    #: Also the node id of the discovery topics, so only letters, digits, "_" and "-".
    mqtt_client_id: str = Field("homebot", pattern=r"^[A-Za-z0-9_\-]{1,64}$")
    mqtt_discovery_prefix: str = Field("homeassistant", pattern=r"^[A-Za-z0-9_\-/]+$")
    mqtt_map_interval_s: float = Field(5.0, ge=1.0)

    @field_validator("cors_origins", mode="before")
    @classmethod
    def _split_origins(cls, value):
        """Accept ``"https://a, https://b"`` as well as a list."""
        if isinstance(value, str):
            return [o.strip() for o in value.split(",") if o.strip()]
        return value

    @field_validator("world")
    @classmethod
    def _known_world(cls, value: str) -> str:
        if value not in WORLDS:
            raise ValueError(f"unknown world {value!r}; choose one of {', '.join(WORLDS)}")
        return value

    @field_validator("tile_size")
    @classmethod
    def _power_of_two(cls, value: int) -> int:
        if value < 16 or value > 256 or value & (value - 1):
            raise ValueError(f"tile_size must be a power of two in 16..256, got {value}")
        return value

    @model_validator(mode="after")
    def _replay_is_not_simulated(self) -> Settings:
        """A replayed log takes the place of the simulated robot too."""
        if self.replay:
            self.simulation = False
        return self

    @model_validator(mode="after")
    def _mqtt_settings_fit_together(self) -> Settings:
        """A CA file is read only with TLS and must be a file; a password needs a username."""
        if self.mqtt_ca_file is not None:
            if not self.mqtt_tls:
                raise ValueError("HOMEBOT_MQTT_CA_FILE is used only with HOMEBOT_MQTT_TLS=1")
            if not self.mqtt_ca_file.is_file():
                raise ValueError(f"HOMEBOT_MQTT_CA_FILE {self.mqtt_ca_file} is not a file")
        if self.mqtt_password is not None and not self.mqtt_username:
            raise ValueError("HOMEBOT_MQTT_PASSWORD needs HOMEBOT_MQTT_USERNAME")
        return self

    def robot_config(self) -> RobotConfig:
        """The robot described by ``robot`` (read once per process)."""
        from slam_core.robot_config import robot_from

        return robot_from(self.robot)

    def slam(self) -> RBPFConfig:
        """The SLAM settings: the ``slam_config`` file or the defaults (read once per process)."""
        return _slam_from(self.slam_config)

    @property
    def resolution(self) -> float:
        """The map's cell size (m), the SLAM settings'."""
        return self.slam().resolution

    @property
    def db_path(self) -> Path:
        return self.data_dir / "homebot.sqlite3"

    @property
    def maps_dir(self) -> Path:
        return self.data_dir / "maps"

    @property
    def sessions_dir(self) -> Path:
        return self.data_dir / "sessions"

    def session_file(self, name: str) -> Path:
        """Where the mapping session ``name`` is saved (see :mod:`slam_core.session`)."""
        from app.db.names import check_name
        from slam_core.session import SUFFIX

        return self.sessions_dir / f"{check_name(name, 'session name')}{SUFFIX}"

    @property
    def replay_dir(self) -> Path:
        return self.data_dir / "replay"

    @property
    def checkpoint_dir(self) -> Path:
        return self.data_dir / "checkpoint"

    @property
    def last_map_stem(self) -> Path:
        return self.data_dir / "last_map"


@lru_cache(maxsize=8)
def _slam_from(path: Path | None) -> RBPFConfig:
    from slam_core.rbpf.config import RBPFConfig

    return RBPFConfig() if path is None else RBPFConfig.from_file(path)
