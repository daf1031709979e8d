# alpaca-zwo in a container. Discovery (UDP broadcast) needs host networking:
#   docker build -t alpaca-zwo .
#   docker run --rm --network host --device /dev/ttyACM0 -v alpaca-zwo:/config alpaca-zwo --device /dev/ttyACM0
# Without --device the built-in emulator is used. The config (with the persistent UniqueID) lives in /config.
FROM python:3.11-slim

ENV PYTHONDONTWRITEBYTECODE=1 PYTHONUNBUFFERED=1 PIP_NO_CACHE_DIR=1
WORKDIR /src
COPY pyproject.toml README.md ./
COPY alpaca_zwo ./alpaca_zwo
COPY static ./static
RUN pip install . && rm -rf /src

# A non-root user that may open serial ports (dialout) and owns the config volume.
RUN useradd --create-home --uid 1000 --groups dialout alpaca \
    && mkdir -p /config && chown alpaca:alpaca /config
USER alpaca
VOLUME ["/config"]
EXPOSE 11111/tcp 32227/udp

HEALTHCHECK --interval=30s --timeout=5s --start-period=10s --retries=3 \
    CMD python -c "import urllib.request,sys; urllib.request.urlopen('http://127.0.0.1:11111/management/apiversions', timeout=4); sys.exit(0)"

ENTRYPOINT ["alpaca-zwo", "--config", "/config/config.toml"]
