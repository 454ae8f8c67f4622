/* libmodbus as the other side of ferrule's Modbus peer tests (tests/peers/peers_test.py).
 *
 *   libmodbus_peer rtu-server TTY UNIT   serve the peer map on a serial line (8N1: ptys)
 *   libmodbus_peer tcp-server PORT       serve the peer map on 127.0.0.1:PORT
 *   libmodbus_peer rtu-client TTY UNIT   check a server of the peer map, every function
 *   libmodbus_peer tcp-client PORT UNIT  the same over TCP on 127.0.0.1
 *   libmodbus_peer rtu-registers TTY UNIT ADDR COUNT [VALUE...]
 *                                        write the VALUEs to the holding registers from ADDR
 *                                        (FC 16), then read COUNT from ADDR (FC 3) and print
 *                                        them in decimal on one line (a server's own map)
 *   libmodbus_peer tcp-client-stray-zeros PORT UNIT
 *                                        eight zero bytes on the connection between two
 *                                        requests: the server closes it at once, libmodbus
 *                                        connects again, and the requests after it succeed
 *
 * The peer map is the same on both sides (tests/peers/README.md):
 *   coils 0-99: bit i = (i % 3 == 0)     discrete inputs 0-99: bit i = (i % 2 == 1)
 *   holding registers 0-99: 0x1000 + i   input registers 0-99: 0x2000 + i
 * ferrule's server adds what libmodbus's lacks: diagnostics (FC 8), device identification
 * (FC 43/14: "ferrule" / "FR-PEER" / "1.0"), and exception 04 for a write of 0xDEAD to
 * holding register 99; this client checks the last only with --ferrule-extras (libmodbus
 * cannot frame FC 8 / 43 responses; pymodbus_peer.py checks them).
 * The clients print "ok NAME" or "FAIL NAME: why" per check and end with "N passed, M failed".
 */
#include <errno.h>
#include <modbus.h>
#include <signal.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <time.h>
#include <unistd.h>

enum { map_size = 100 };

static int passed, failed;

static void check(const char* name, int ok, const char* why) {
    if (ok) {
        ++passed;
        printf("ok %s\n", name);
    } else {
        ++failed;
        printf("FAIL %s: %s\n", name, why);
    }
    fflush(stdout);
}

static volatile sig_atomic_t stop;
static void on_signal(int s) {
    (void)s;
    stop = 1;
}

static modbus_mapping_t* peer_map(void) {
    modbus_mapping_t* m = modbus_mapping_new(map_size, map_size, map_size, map_size);
    for (int i = 0; i < map_size; ++i) {
        m->tab_bits[i] = i % 3 == 0;
        m->tab_input_bits[i] = i % 2 == 1;
        m->tab_registers[i] = (uint16_t)(0x1000 + i);
        m->tab_input_registers[i] = (uint16_t)(0x2000 + i);
    }
    return m;
}

static int serve_rtu(modbus_t* ctx) {
    modbus_mapping_t* m = peer_map();
    uint8_t req[MODBUS_RTU_MAX_ADU_LENGTH];
    printf("ready\n");
    fflush(stdout);
    while (!stop) {
        const int n = modbus_receive(ctx, req);
        if (n > 0) modbus_reply(ctx, req, n, m);
        /* n == 0: a request for another unit; n < 0: CRC error or timeout, keep listening */
    }
    modbus_mapping_free(m);
    return 0;
}

static int serve_tcp(modbus_t* ctx) {
    modbus_mapping_t* m = peer_map();
    int listener = modbus_tcp_listen(ctx, 1);
    if (listener < 0) {
        fprintf(stderr, "listen: %s\n", modbus_strerror(errno));
        return 1;
    }
    printf("ready\n");
    fflush(stdout);
    uint8_t req[MODBUS_TCP_MAX_ADU_LENGTH];
    while (!stop) {
        if (modbus_tcp_accept(ctx, &listener) < 0) break;
        for (;;) {
            const int n = modbus_receive(ctx, req);
            if (n < 0) break; /* the client closed the connection */
            modbus_reply(ctx, req, n, m);
        }
        modbus_close(ctx);
    }
    modbus_mapping_free(m);
    return 0;
}

/* A request libmodbus has no function for: sends `pdu` to the unit, the answer in rsp. */
static int raw(modbus_t* ctx, int unit, const uint8_t* pdu, int n, uint8_t* rsp) {
    uint8_t req[MODBUS_MAX_PDU_LENGTH + 1];
    req[0] = (uint8_t)unit;
    memcpy(req + 1, pdu, (size_t)n);
    if (modbus_send_raw_request(ctx, req, n + 1) < 0) return -1;
    return modbus_receive_confirmation(ctx, rsp);
}

static int client(modbus_t* ctx, int unit, int extras) {
    char why[160];
    uint8_t bits[128];
    uint16_t regs[128];
    modbus_set_slave(ctx, unit);
    modbus_set_response_timeout(ctx, 1, 0);

    int rc = modbus_read_bits(ctx, 0, 20, bits);
    int ok = rc == 20;
    for (int i = 0; ok && i < 20; ++i) ok = bits[i] == (i % 3 == 0);
    snprintf(why, sizeof why, "rc %d (%s)", rc, modbus_strerror(errno));
    check("FC1 read coils 0-19", ok, why);

    rc = modbus_read_input_bits(ctx, 3, 20, bits);
    ok = rc == 20;
    for (int i = 0; ok && i < 20; ++i) ok = bits[i] == ((i + 3) % 2 == 1);
    check("FC2 read discrete inputs 3-22", ok, why);

    rc = modbus_read_registers(ctx, 0, 10, regs);
    ok = rc == 10;
    for (int i = 0; ok && i < 10; ++i) ok = regs[i] == 0x1000 + i;
    snprintf(why, sizeof why, "rc %d (%s)", rc, modbus_strerror(errno));
    check("FC3 read holding registers 0-9", ok, why);

    rc = modbus_read_registers(ctx, 0, 125, regs);
    check("FC3 125 registers is one more than the map: exception 02",
          rc < 0 && errno == EMBXILADD, modbus_strerror(errno));

    rc = modbus_read_input_registers(ctx, 90, 10, regs);
    ok = rc == 10;
    for (int i = 0; ok && i < 10; ++i) ok = regs[i] == 0x2000 + 90 + i;
    check("FC4 read input registers 90-99", ok, modbus_strerror(errno));

    ok = modbus_write_bit(ctx, 10, 1) == 1 && modbus_read_bits(ctx, 10, 1, bits) == 1 && bits[0];
    check("FC5 write coil 10 on, read back", ok, modbus_strerror(errno));

    ok = modbus_write_register(ctx, 5, 0x1234) == 1 && modbus_read_registers(ctx, 5, 1, regs) == 1 &&
         regs[0] == 0x1234;
    check("FC6 write register 5, read back", ok, modbus_strerror(errno));

    uint8_t pattern[10] = {1, 1, 0, 1, 0, 0, 1, 0, 1, 1};
    ok = modbus_write_bits(ctx, 20, 10, pattern) == 10 && modbus_read_bits(ctx, 20, 10, bits) == 10 &&
         memcmp(bits, pattern, 10) == 0;
    check("FC15 write coils 20-29, read back", ok, modbus_strerror(errno));

    const uint16_t values[5] = {1, 2, 0xFFFF, 0x8000, 42};
    ok = modbus_write_registers(ctx, 30, 5, values) == 5 &&
         modbus_read_registers(ctx, 30, 5, regs) == 5 && memcmp(regs, values, sizeof values) == 0;
    check("FC16 write registers 30-34, read back", ok, modbus_strerror(errno));

    const uint16_t w[2] = {0xAAAA, 0x5555};
    ok = modbus_write_and_read_registers(ctx, 40, 2, w, 39, 4, regs) == 4 && regs[0] == 0x1000 + 39 &&
         regs[1] == 0xAAAA && regs[2] == 0x5555 && regs[3] == 0x1000 + 42;
    check("FC23 write 40-41 and read 39-42 in one request", ok, modbus_strerror(errno));

    rc = modbus_read_registers(ctx, 100, 1, regs);
    check("exception 02: read holding register 100", rc < 0 && errno == EMBXILADD,
          modbus_strerror(errno));

    uint8_t rsp[MODBUS_MAX_ADU_LENGTH];
    const int h = modbus_get_header_length(ctx);
    const uint8_t too_many[] = {0x03, 0x00, 0x00, 0x00, 126};
    rc = raw(ctx, unit, too_many, sizeof too_many, rsp);
    check("exception 03: read 126 registers", rc > 0 && rsp[h] == 0x83 && rsp[h + 1] == 3,
          modbus_strerror(errno));
    if (h != 1 || extras) { /* libmodbus's RTU server cannot frame a function it does not know */
        const uint8_t unknown[] = {0x41, 0x00};
        rc = raw(ctx, unit, unknown, sizeof unknown, rsp);
        check("exception 01: function 0x41", rc > 0 && rsp[h] == 0xC1 && rsp[h + 1] == 1,
              modbus_strerror(errno));
    }

    if (extras) {
        /* libmodbus has no functions for FC 8 and FC 43 and cannot frame their responses:
         * pymodbus checks those. */
        rc = modbus_write_register(ctx, 99, 0xDEAD);
        check("exception 04: server device failure", rc < 0 && errno == EMBXSFAIL,
              modbus_strerror(errno));
    }

    if (h == 1) { /* RTU: a broadcast is executed and not answered */
        modbus_set_slave(ctx, 0);
        /* libmodbus 3.1.6 waits for a reply to a broadcast and reports a timeout: its result
         * says nothing here; reading the register back does. */
        (void)modbus_write_register(ctx, 50, 0x0777);
        modbus_set_slave(ctx, unit);
        usleep(100000); /* the turnaround delay after a broadcast (Serial Line V1.02 §2.4.1) */
        ok = modbus_read_registers(ctx, 50, 1, regs) == 1 && regs[0] == 0x0777;
        check("broadcast write register 50, read back from the unit", ok, modbus_strerror(errno));
    }

    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

static long ms_since(const struct timespec* t0) {
    struct timespec t;
    clock_gettime(CLOCK_MONOTONIC, &t);
    return (t.tv_sec - t0->tv_sec) * 1000 + (t.tv_nsec - t0->tv_nsec) / 1000000;
}

/* Eight zero bytes form an MBAP header of length 0, which starts no request: a server that
 * resynchronises byte by byte takes the request behind them for part of a frame and never
 * answers it, so the client times out; a server that closes the connection lets libmodbus's
 * link recovery connect again at once. */
static int stray_zeros(modbus_t* ctx, int unit) {
    char why[160];
    uint16_t regs[10];
    modbus_set_slave(ctx, unit);
    modbus_set_response_timeout(ctx, 2, 0);
    modbus_set_error_recovery(ctx, MODBUS_ERROR_RECOVERY_LINK);

    /* Transaction 1; the one after the zeros is 2, with which they frame as a header. */
    int rc = modbus_read_registers(ctx, 0, 10, regs);
    check("FC3 before the stray bytes", rc == 10 && regs[9] == 0x1000 + 9, modbus_strerror(errno));

    static const uint8_t zeros[8];
    const ssize_t written = write(modbus_get_socket(ctx), zeros, sizeof zeros);
    check("eight zero bytes written on the connection", written == (ssize_t)sizeof zeros,
          strerror(errno));

    struct timespec t0;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    rc = modbus_read_registers(ctx, 0, 10, regs);
    const int err = errno;
    snprintf(why, sizeof why, "rc %d (%s) after %ld ms", rc, modbus_strerror(err), ms_since(&t0));
    check("the request after them fails at once: the server closed the connection (not a "
          "timeout)",
          rc == -1 && err == ECONNRESET, why);

    int ok = 1;
    for (int i = 0; i < 20 && ok; ++i) {
        rc = modbus_read_registers(ctx, i, 1, regs);
        ok = rc == 1 && regs[0] == 0x1000 + i;
        snprintf(why, sizeof why, "request %d: rc %d (%s)", i, rc, modbus_strerror(errno));
    }
    check("connected again: 20 requests after it succeed", ok, why);

    printf("%d passed, %d failed\n", passed, failed);
    return failed ? 1 : 0;
}

/* rtu-registers: what a server of any map holds, for tests that check it against others. */
static int registers(modbus_t* ctx, int unit, int address, int count, char** values, int n) {
    uint16_t regs[MODBUS_MAX_READ_REGISTERS];
    if (count < 1 || count > MODBUS_MAX_READ_REGISTERS || n > MODBUS_MAX_WRITE_REGISTERS) return 2;
    modbus_set_slave(ctx, unit);
    modbus_set_response_timeout(ctx, 1, 0);
    for (int i = 0; i < n; ++i) regs[i] = (uint16_t)strtoul(values[i], NULL, 0);
    if (n > 0 && modbus_write_registers(ctx, address, n, regs) != n) {
        fprintf(stderr, "libmodbus: write: %s\n", modbus_strerror(errno));
        return 1;
    }
    if (modbus_read_registers(ctx, address, count, regs) != count) {
        fprintf(stderr, "libmodbus: read: %s\n", modbus_strerror(errno));
        return 1;
    }
    for (int i = 0; i < count; ++i) printf(i ? " %u" : "%u", regs[i]);
    printf("\n");
    return 0;
}

int main(int argc, char** argv) {
    if (argc < 3) {
        fprintf(stderr, "usage: %s rtu-server TTY UNIT | tcp-server PORT | rtu-client TTY UNIT "
                        "[--ferrule-extras] | tcp-client PORT UNIT [--ferrule-extras] | "
                        "rtu-registers TTY UNIT ADDR COUNT [VALUE...] | "
                        "tcp-client-stray-zeros PORT UNIT\n",
                argv[0]);
        return 2;
    }
    signal(SIGTERM, on_signal);
    signal(SIGINT, on_signal);
    const char* mode = argv[1];
    const int rtu = strncmp(mode, "rtu", 3) == 0;
    modbus_t* ctx = rtu ? modbus_new_rtu(argv[2], 19200, 'N', 8, 1)
                        : modbus_new_tcp("127.0.0.1", atoi(argv[2]));
    if (!ctx || ((rtu || strstr(mode, "client")) && modbus_connect(ctx) < 0)) {
        fprintf(stderr, "libmodbus: %s\n", modbus_strerror(errno));
        return 3;
    }
    const int extras = argc > 4 && strcmp(argv[argc - 1], "--ferrule-extras") == 0;
    int rc = 2;
    if (strcmp(mode, "rtu-server") == 0 && argc > 3) {
        modbus_set_slave(ctx, atoi(argv[3]));
        rc = serve_rtu(ctx);
    } else if (strcmp(mode, "tcp-server") == 0) {
        rc = serve_tcp(ctx);
    } else if ((strcmp(mode, "rtu-client") == 0 || strcmp(mode, "tcp-client") == 0) && argc > 3) {
        rc = client(ctx, atoi(argv[3]), extras);
    } else if (strcmp(mode, "rtu-registers") == 0 && argc > 5) {
        rc = registers(ctx, atoi(argv[3]), atoi(argv[4]), atoi(argv[5]), argv + 6, argc - 6);
    } else if (strcmp(mode, "tcp-client-stray-zeros") == 0 && argc > 3) {
        rc = stray_zeros(ctx, atoi(argv[3]));
    }
    modbus_close(ctx);
    modbus_free(ctx);
    return rc;
}
