# homebot in a container: the README's install steps (pip install of the project), run as a non-root
# user, with maps and the database in the /data volume. Simulation mode unless HOMEBOT_SIMULATION=false.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 \
    PYTHONUNBUFFERED=1 \
    PIP_NO_CACHE_DIR=1 \
    PIP_DISABLE_PIP_VERSION_CHECK=1 \
    NUMBA_CACHE_DIR=/home/homebot/.cache/numba \
    HOMEBOT_DATA_DIR=/data \
    HOMEBOT_HOST=0.0.0.0 \
    HOMEBOT_PORT=8000

RUN useradd --create-home --uid 1000 --user-group homebot \
 && mkdir -p /app /data \
 && chown homebot:homebot /app /data
WORKDIR /app

# Dependencies in their own cached layer: rebuilt only when pyproject.toml changes. Empty package
# folders let pip resolve the project; the real sources come in the next layer.
COPY pyproject.toml README.md ./
RUN mkdir -p app slam_core && touch app/__init__.py slam_core/__init__.py \
 && pip install -e . \
 && rm -rf app slam_core homebot.egg-info

COPY --chown=homebot:homebot . .
RUN pip install --no-deps -e . && chown -R homebot:homebot /app

USER homebot
# Compile the numba kernels once at build time (cache in NUMBA_CACHE_DIR): the first start is fast.
RUN python docker/warm_numba_cache.py

VOLUME ["/data"]
EXPOSE 8000
# Unhealthy while api/health says "degraded" (worker crash-looping, robot not localized) or no answer.
HEALTHCHECK --interval=30s --timeout=5s --start-period=60s --retries=3 \
  CMD ["python", "docker/healthcheck.py"]
CMD ["homebot", "serve", "--host", "0.0.0.0"]
