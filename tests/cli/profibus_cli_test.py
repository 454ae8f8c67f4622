#!/usr/bin/env python3
"""`ferrule decode profibus` on the golden telegrams of protocols/modbus_profibus.md §B.9
(master 2, slave 8, ident 0x0815), a real ET200S Slave_Diag reply in SD2 (§B.2), and broken
telegrams.

usage: profibus_cli_test.py <ferrule>
Each check prints 'ok <name>' or 'FAIL <name>: why'; the last line is 'N passed, M failed'.
"""
import subprocess
import sys

from harness import check, json_lines, summary

ferrule = sys.argv[1]


def run(*args, timeout=30):
    p = subprocess.run([ferrule, *args], capture_output=True, text=True, timeout=timeout)
    return p.returncode, p.stdout, p.stderr


FDL_STATUS_REQ = "10 08 02 49 53 16"
FDL_STATUS_RES = "10 02 08 00 0A 16"
SLAVE_DIAG_REQ = "68 05 05 68 88 82 6D 3C 3E F1 16"
SLAVE_DIAG_RES = "A2 82 88 08 3E 3C 02 05 00 FF 08 15 AF 16"
SET_PRM_REQ = "68 0C 0C 68 88 82 7D 3D 3E 88 0A 0A 0B 08 15 00 C6 16"
CHK_CFG_REQ = "68 07 07 68 88 82 6D 3E 3E 11 21 25 16"
SHORT_ACK = "E5"
DATA_EXCH_REQ = "68 05 05 68 08 02 5D 12 34 AD 16"
DATA_EXCH_RES = "68 05 05 68 02 08 08 AB CD 8A 16"
DATA_EXCH_REQ_SD3 = "A2 08 02 5D 00 01 02 03 04 05 06 07 83 16"
GLOBAL_CONTROL = "68 07 07 68 FF 82 46 3A 3E 02 00 41 16"
ET200S_DIAG_RES = "68 0B 0B 68 81 88 08 3E 3C 02 05 00 FF 80 E0 F1 16"

rc, out, _ = run("decode", "profibus", FDL_STATUS_REQ)
check("FDL_Status request from 2 to 8", rc == 0
      and "SD1 request  DA 8 SA 2: FC 0x49 FDL_Status FCB 0 FCV 0, FCS ok" in out, out)

rc, out, _ = run("decode", "profibus", SLAVE_DIAG_RES)
check("Slave_Diag reply in SD3", rc == 0
      and "SD3 response DA 2 SA 8: FC 0x08 DL (data low), station type slave" in out
      and "DSAP 62, SSAP 60, Slave_Diag" in out
      and "Station_Status_1 0x02 Station_Not_Ready;" in out
      and "Station_Status_2 0x05 Prm_Req, always 1;" in out
      and "Diag.Master_Add 255 (none); Ident_Number 0x0815" in out, out)

rc, out, _ = run("decode", "profibus", "--json", FDL_STATUS_REQ, FDL_STATUS_RES, SLAVE_DIAG_REQ,
                 SLAVE_DIAG_RES, SET_PRM_REQ, CHK_CFG_REQ, SHORT_ACK, DATA_EXCH_REQ, DATA_EXCH_RES,
                 DATA_EXCH_REQ_SD3, GLOBAL_CONTROL, ET200S_DIAG_RES)
j = json_lines(out)
check("the golden conversation: one object per telegram, all FCS ok", rc == 0 and len(j) == 12
      and [f["frame"] for f in j] == ["SD1", "SD1", "SD2", "SD3", "SD2", "SD2", "SC", "SD2", "SD2",
                                      "SD3", "SD2", "SD2"]
      and all(f.get("fcs", "ok") == "ok" for f in j)
      and [f["offset"] for f in j[:4]] == [0, 6, 12, 23], out)
if len(j) == 12:
    status_req, status_res, diag_req, diag_res, prm, cfg, ack, dx_req, dx_res, dx8, gc, et = j
    check("FDL_Status reply", status_res["direction"] == "response"
          and status_res["function"] == "OK" and status_res["da"] == 2 and status_res["sa"] == 8,
          str(status_res))
    check("Slave_Diag request: SRD_HI, FCB 1, FCV 0", diag_req["function"] == "SRD_HI"
          and diag_req["fcb"] and not diag_req["fcv"] and diag_req["dsap"] == 60
          and diag_req["ssap"] == 62 and diag_req["service"] == "Slave_Diag", str(diag_req))
    check("Slave_Diag reply fields", diag_res["station_status_1"] == ["Station_Not_Ready"]
          and diag_res["station_status_2"] == ["Prm_Req", "always 1"]
          and diag_res["station_status_3"] == [] and diag_res["master_address"] == 255
          and diag_res["ident_number"] == 0x0815 and diag_res["extended"] == "", str(diag_res))
    check("Set_Prm: Lock_Req and WD_On, 10 x 10 x 10 ms, min TSDR 11, ident 0x0815, group 0",
          prm["service"] == "Set_Prm" and prm["station_status"] == ["Lock_Req", "WD_On"]
          and prm["watchdog_ms"] == 1000 and prm["min_tsdr"] == 11
          and prm["ident_number"] == 0x0815 and prm["group_ident"] == 0
          and prm["user_prm_data"] == "", str(prm))
    check("Chk_Cfg: 0x11 2 bytes in, 0x21 2 bytes out", cfg["service"] == "Chk_Cfg"
          and [(i["id"], i["length"], i["unit"], i["direction"]) for i in cfg["identifiers"]]
          == [(0x11, 2, "bytes", "in"), (0x21, 2, "bytes", "out")], str(cfg))
    check("short acknowledgement", ack["frame"] == "SC" and "da" not in ack, str(ack))
    check("Data_Exchange request and DL reply", dx_req["service"] == "Data_Exchange"
          and dx_req["data"] == "12 34" and "dsap" not in dx_req
          and dx_res["service"] == "Data_Exchange" and dx_res["data"] == "AB CD"
          and dx_res["function"] == "DL (data low)", f"{dx_req} {dx_res}")
    check("Data_Exchange with 8 bytes in SD3", dx8["service"] == "Data_Exchange"
          and dx8["data"] == "00 01 02 03 04 05 06 07", str(dx8))
    check("Global_Control Clear_Data to the broadcast address", gc["da"] == 127
          and gc["function"] == "SDN_HI" and gc["service"] == "Global_Control"
          and gc["control_command"] == ["Clear_Data"] and gc["group_select"] == 0, str(gc))
    check("the ET200S Slave_Diag reply in SD2", et["frame"] == "SD2" and et["da"] == 1
          and et["ident_number"] == 0x80E0 and et["station_status_2"] == ["Prm_Req", "always 1"],
          str(et))

rc, out, _ = run("decode", "profibus", "55", "10 08 02 49 54 16", FDL_STATUS_RES, "68 05")
check("garbage, a bad FCS, a good telegram, a truncated one", rc == 1
      and "@0    not a telegram (not a PROFIBUS telegram): 55" in out
      and "@1    10 08 02 49 54 16          SD1 FCS bad: 0x54, the bytes give 0x53" in out
      and "@7    10 02 08 00 0A 16          SD1 response DA 2 SA 8" in out
      and "@13   not a telegram (incomplete or not a PROFIBUS telegram): 68 05" in out, out)
rc, out, _ = run("decode", "profibus", "--json", "68 05 05 68 08 02 5D 12 34 AE 16", SHORT_ACK)
j = json_lines(out)
check("a bad FCS in SD2, then the decoder goes on", rc == 1 and len(j) == 2
      and j[0] == {"offset": 0, "bytes": "68 05 05 68 08 02 5D 12 34 AE 16", "frame": "SD2",
                   "fcs": "bad", "error": "checksum mismatch"}
      and j[1]["frame"] == "SC" and j[1]["offset"] == 11, out)

sys.exit(summary())
