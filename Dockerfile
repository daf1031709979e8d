# alpaca-zwo in a container. Discovery (UDP broadcast) needs host networking:
#   docker build -t alpaca-zwo .
#   docker run --rm --network host --device /dev/ttyACM0 -v alpaca-zwo:/config alpaca-zwo --device /dev/ttyACM0
# Without --device the built-in emulator is used. The config (with the persistent UniqueID) lives in /config.
# No compiler needed: wheels for amd64 and arm64 (armv7 lacks pyerfa/numpy wheels: tests/platform/test_platform_wheels.py).
# Built and checked by tests/platform/test_platform_container.py.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 PYTHONUNBUFFERED=1 PIP_NO_CACHE_DIR=1
WORKDIR /src
COPY pyproject.toml README.md ./
COPY alpaca_zwo ./alpaca_zwo
COPY static ./static
# docs/: the user guide the server serves at /docs (package data of alpaca_zwo.docs)
COPY docs ./docs
RUN pip install . && rm -rf /src

# A non-root user that may open serial ports (dialout) and owns the config volume.
RUN useradd --create-home --uid 1000 --groups dialout alpaca \
    && mkdir -p /config && chown alpaca:alpaca /config
USER alpaca
VOLUME ["/config"]
EXPOSE 11111/tcp 32227/udp

# Asks /management/apiversions on the port the server was given (--port, or server.port in /config).
HEALTHCHECK --interval=30s --timeout=5s --start-period=10s --retries=3 \
    CMD ["python", "-m", "alpaca_zwo.healthcheck"]

ENTRYPOINT ["alpaca-zwo", "--config", "/config/config.toml"]
