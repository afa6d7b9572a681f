// trav_unit: the fixed-point device's traversal unit. SLOTS ray slots walk a BVH of quantized axis-aligned
// nodes (the struct layout, 8-bit child offsets, N children) and test leaf triangles; one box unit (box_unit.sv,
// LANES tests per clock) and one triangle unit (tri_core.sv) serve them; one memory port brings nodes, triangle
// records and spilled stack entries; one hit port writes each ray's answer. It is the timing model's unit
// (hwmodel/timing/timing_model.h) with box_units = tri_units = tri_rate = 1, built to be held against it cycle
// for cycle (rtl_sim/trav/README.md says where the two differ and why).
//
// What each slot does, as the fixed tracer's traversal (hwmodel/datapath/traverse.h) does it:
//   - a ray arrives set up (FixedRay's fields; setup stays in C++) and after SETUP_LAT clocks fetches the root;
//   - a node: its children's boxes through the box unit; the hit children sorted by entry distance (stable: ties
//     keep slot order); the nearest becomes the next node, the others are pushed farthest first;
//   - a leaf: its records in order, one fetch and one triangle test each; a hit at t <= the closest replaces it
//     (so among equal t the later record wins, as in the C++); an any-hit ray stops at its first hit;
//   - then pops: an entry whose distance is beyond the closest hit is dropped; the stack is empty: write-back.
// The short stack holds STACK entries; a push beyond it writes the entry to memory (a spill, in push order), a pop
// of such an entry reads it back (a refill) and waits for it. Every step after a unit result waits TRAV_LAT clocks.
//
// Shared resources go to the oldest request first (ties: the lowest slot): the box and triangle units by the cycle
// the request's data arrived (as the timing model serves unit requests), the memory port by the cycle the slot
// became ready to ask (reads before spill writes), the hit port likewise, a new ray to the slot free longest.
// A unit request may be granted in the cycle its data arrives (the response feeds the unit directly).
//
// Memory port: a request is taken at a rising edge with mem_req_valid && mem_req_ready; reads (nodes NB bytes,
// records 40 bytes, stack entries 8 bytes) carry the slot as their id and are answered on mem_resp_* at any later
// edge, in any order, at most one response per edge, each read answered once; writes (spills) are not answered.
// A stack entry is its reference (bits 31:0) and its entry distance (bits 32 +: TB + 2); the memory behind the
// port keeps whatever a write gave and a read of the same address returns it (addresses as the timing model's
// stack_addr: cfg_stack_base + ((index % 512) * SLOTS + slot) * 8).
// Hit port: valid/ready; a slot is free for a new ray the clock after its hit is taken.
module trav_unit #(
    parameter int SLOTS     = 4,   // ray slots (ray_slots)
    parameter int STACK     = 8,   // short stack entries per slot (stack_entries)
    parameter int SETUP_LAT = 4,   // clocks from a ray's arrival to its first fetch (setup_latency, >= 1)
    parameter int TRAV_LAT  = 1,   // clocks from a unit result to the slot's next request (traversal_latency, >= 1)
    // The box unit (box_unit.sv; rtl_sim/params/rtl_params.h derives them)
    parameter int N         = 4,
    parameter int LANES     = 4,
    parameter int K         = 8,   // child offset bits (<= 8: one byte per offset)
    parameter int A         = 39,  // B+G+F+1
    parameter int M         = 21,
    parameter int TB        = 56,
    parameter int SHW       = 6,
    parameter int RSH       = 12,
    parameter int LSH       = 12,
    parameter int BOX_LAT   = 6,
    // The triangle unit (tri_core.sv; rtl_sim/params/tri_params.h)
    parameter int B         = 24,
    parameter int F         = 8,
    parameter int D         = 24,
    parameter int S         = 32,
    parameter int TRI_LAT   = 12,
    parameter int IDW       = 24,  // ray id bits
    localparam int SW       = SLOTS > 1 ? $clog2(SLOTS) : 1,
    localparam int NB       = 16 + 10 * N,               // node bytes (hw::qnode_bytes(N, 1))
    localparam int MB       = NB > 40 ? NB : 40,         // widest read
    localparam int MDW      = 8 * MB,
    localparam int DW       = D + 2,
    localparam int EW       = 2 * A + D + 4,
    localparam int RSW      = $clog2((LSH > RSH ? LSH : RSH) + 1) + 1,
    localparam int NDW      = TB + 2,                     // entry distance (t_near)
    localparam int SEW      = 32 + NDW                    // stack entry
) (
    input logic clk,
    input logic rst,
    // Configuration, held while rays are in flight.
    input logic [63:0] cfg_node_base,   // byte address of node 0
    input logic [63:0] cfg_rec_base,    // byte address of record 0
    input logic [63:0] cfg_stack_base,  // the slots' stack region
    input logic [31:0] cfg_root,        // the root's reference
    // Rays, set up.
    input  logic                ray_valid,
    output logic                ray_ready,
    input  logic [     IDW-1:0] ray_id,
    input  logic                ray_any_hit,
    input  logic [     3*A-1:0] ray_o,        // grid.F origin, signed, axis a at [a*A +: A]
    input  logic [    3*DW-1:0] ray_d,        // direction, signed
    input  logic [ 3*(M+2)-1:0] ray_rcpm_dn,
    input  logic [ 3*(M+2)-1:0] ray_rcpm_up,
    input  logic [   3*RSW-1:0] ray_rcp_sh,
    input  logic [         2:0] ray_zero,
    input  logic [         2:0] ray_neg,
    input  logic [        TB:0] ray_tmin,
    input  logic [        TB:0] ray_tmax,
    // Memory.
    output logic                mem_req_valid,
    input  logic                mem_req_ready,
    output logic [      SW-1:0] mem_req_id,
    output logic                mem_req_write,
    output logic [        63:0] mem_req_addr,
    output logic [         7:0] mem_req_bytes,
    output logic [     SEW-1:0] mem_req_wdata,
    input  logic                mem_resp_valid,
    input  logic [      SW-1:0] mem_resp_id,
    input  logic [     MDW-1:0] mem_resp_data,
    // Hits.
    output logic                hit_valid,
    input  logic                hit_ready,
    output logic [     IDW-1:0] hit_id,
    output logic                hit_found,
    output logic [        TB:0] hit_t,
    output logic [        31:0] hit_prim,     // the record's last word (kind, flags, primitive index)
    output logic [      EW-1:0] hit_e1,
    output logic [      EW-1:0] hit_e2,
    output logic [      EW-1:0] hit_det,
    output logic                busy
);
  initial begin
    if (K > 8) $error("trav_unit: child offsets of more than 8 bits are not supported");
    if (SETUP_LAT < 1 || TRAV_LAT < 1) $error("trav_unit: SETUP_LAT and TRAV_LAT must be >= 1");
  end

  localparam int DEPW = 10;  // stack depth: up to hw::kTraversalStackSize (640)
  localparam int CW = $clog2(N + 1);
  localparam int CNTW = 8;
  localparam int STW = STACK > 1 ? $clog2(STACK) : 1;  // short stack index
  localparam int SPW = N > 1 ? $clog2(N) : 1;          // pending spill index

  typedef enum logic [2:0] {
    IDLE,      // free
    ACT,       // counting down to its next action (cnt), then acting: fetch, refill or write-back
    MEM,       // a read outstanding
    BOX,       // node data here, waiting for the box unit
    TRI,       // record data here, waiting for the triangle unit
    UNIT,      // in a unit
    WB         // waiting for the hit port
  } state_t;
  typedef enum logic [1:0] {
    RD_NODE,
    RD_REC,
    RD_ENTRY
  } rd_t;

  logic [31:0] now;

  // ---- Slot state ----
  state_t                st       [SLOTS];
  logic   [    CNTW-1:0] cnt      [SLOTS];
  logic   [        31:0] ts       [SLOTS];  // arrival of its data (BOX, TRI), or when it became ready (ACT, WB)
  rd_t                   rd       [SLOTS];
  logic   [     IDW-1:0] rid      [SLOTS];
  logic                  any_hit  [SLOTS];
  logic signed [A-1:0]   o        [SLOTS][3];
  logic   [    3*DW-1:0] dvec     [SLOTS];
  logic   [ 3*(M+2)-1:0] rcpm_dn  [SLOTS];
  logic   [ 3*(M+2)-1:0] rcpm_up  [SLOTS];
  logic   [   3*RSW-1:0] rcp_sh   [SLOTS];
  logic   [         2:0] zero     [SLOTS];
  logic   [         2:0] neg      [SLOTS];
  logic   [        TB:0] tmin     [SLOTS];
  logic signed [TB:0]    ct       [SLOTS];  // the closest hit's t (the ray's tmax before one)
  logic                  found    [SLOTS];
  logic   [        31:0] prim     [SLOTS];
  logic   [      EW-1:0] e1       [SLOTS];
  logic   [      EW-1:0] e2       [SLOTS];
  logic   [      EW-1:0] det      [SLOTS];
  logic                  have_cur [SLOTS];  // cur names the next node or leaf
  logic   [        31:0] cur      [SLOTS];
  logic   [        31:0] rec_idx  [SLOTS];  // in a leaf: the next record
  logic   [         4:0] rec_left [SLOTS];  // records of the leaf not yet tested (0: not in a leaf)
  logic                  done     [SLOTS];  // an any-hit ray has its hit
  logic   [    DEPW-1:0] depth    [SLOTS];
  logic   [        31:0] sref     [SLOTS][STACK];
  logic signed [NDW-1:0] sdist    [SLOTS][STACK];
  logic   [     MDW-1:0] data     [SLOTS];  // the fetched node or record
  // Spills not yet written: stack positions [sp_from, sp_from + sp_n) with their entries, in push order.
  logic   [    DEPW-1:0] sp_from  [SLOTS];
  logic   [         3:0] sp_n     [SLOTS];
  logic   [     SEW-1:0] sp_ent   [SLOTS][N];

  // ---- Field access ----
  function automatic logic [31:0] word(input logic [MDW-1:0] bytes, input integer at);
    word = bytes[8*at+:32];
  endfunction
  function automatic logic [63:0] entry_addr(input logic [DEPW-1:0] pos, input logic [SW-1:0] slot);
    logic [63:0] i;
    i = (64'(pos) - 64'(STACK)) & 64'h1FF;
    entry_addr = cfg_stack_base + ((i * 64'(SLOTS) + 64'(slot)) << 3);
  endfunction

  // ---- What each slot asks for this cycle ----
  // A slot in ACT with cnt == 0 acts: its read (a node or record fetch, or a refill), or the write-back. The
  // on-chip pop search: the highest entry below depth whose distance is not beyond the closest hit.
  logic              want_rd  [SLOTS];
  logic              want_wb  [SLOTS];
  rd_t               act_rd   [SLOTS];
  logic [63:0]       act_addr [SLOTS];
  logic [7:0]        act_bytes[SLOTS];
  logic [31:0]       act_ref  [SLOTS];  // the node or leaf fetched (a popped entry's, or cur)
  logic              act_pop  [SLOTS];  // the action pops the on-chip stack to act_depth
  logic [DEPW-1:0]   act_depth[SLOTS];
  always_comb begin
    for (int k = 0; k < SLOTS; k++) begin
      logic        has;
      logic [31:0] r;
      logic [DEPW-1:0] nd;
      want_rd[k] = 1'b0;
      want_wb[k] = 1'b0;
      act_rd[k] = RD_NODE;
      act_addr[k] = '0;
      act_bytes[k] = '0;
      act_ref[k] = '0;
      act_pop[k] = 1'b0;
      act_depth[k] = depth[k];
      has = 1'b0;
      r = '0;
      nd = depth[k];
      if (st[k] == ACT && cnt[k] == 0 && sp_n[k] == 0) begin
        if (done[k]) begin
          want_wb[k] = 1'b1;
        end else if (rec_left[k] != 0) begin
          want_rd[k] = 1'b1;
          act_rd[k] = RD_REC;
          act_addr[k] = cfg_rec_base + 64'(rec_idx[k]) * 64'd40;
          act_bytes[k] = 8'd40;
        end else if (have_cur[k]) begin
          has = 1'b1;
          r = cur[k];
        end else if (depth[k] > DEPW'(STACK)) begin
          want_rd[k] = 1'b1;
          act_rd[k] = RD_ENTRY;
          act_addr[k] = entry_addr(depth[k] - 1'b1, SW'(k));
          act_bytes[k] = 8'd8;
        end else begin
          nd = '0;
          for (int j = 0; j < STACK; j++)
            if (DEPW'(j) < depth[k] && !($signed({ct[k][TB], ct[k]}) < sdist[k][j])) begin
              has = 1'b1;
              r = sref[k][j];
              nd = DEPW'(j);
            end
          act_pop[k] = 1'b1;
          act_depth[k] = nd;
          if (!has) want_wb[k] = 1'b1;
        end
        if (has) begin
          want_rd[k] = 1'b1;
          act_ref[k] = r;
          if (r[31]) begin
            act_rd[k] = RD_REC;
            act_addr[k] = cfg_rec_base + 64'(r[26:0]) * 64'd40;
            act_bytes[k] = 8'd40;
          end else begin
            act_rd[k] = RD_NODE;
            act_addr[k] = cfg_node_base + 64'(r) * 64'(NB);
            act_bytes[k] = 8'(NB);
          end
        end
      end
    end
  end

  // Memory port: reads first, then spill writes.
  logic [SLOTS-1:0] rd_req, wr_req;
  logic [SLOTS*32-1:0] act_ts;
  logic [SW:0] rd_win, wr_win;
  always_comb begin
    for (int k = 0; k < SLOTS; k++) begin
      rd_req[k] = want_rd[k];
      wr_req[k] = st[k] != IDLE && sp_n[k] != 0;
      act_ts[32*k+:32] = ts[k];
    end
  end
  trav_oldest #(.SLOTS(SLOTS)) u_rd_arb (.req(rd_req), .t(act_ts), .win(rd_win));
  trav_oldest #(.SLOTS(SLOTS)) u_wr_arb (.req(wr_req), .t(act_ts), .win(wr_win));
  always_comb begin
    mem_req_valid = 1'b0;
    mem_req_id = '0;
    mem_req_write = 1'b0;
    mem_req_addr = '0;
    mem_req_bytes = '0;
    mem_req_wdata = '0;
    if (!rd_win[SW]) begin
      mem_req_valid = 1'b1;
      mem_req_id = rd_win[SW-1:0];
      mem_req_addr = act_addr[rd_win[SW-1:0]];
      mem_req_bytes = act_bytes[rd_win[SW-1:0]];
    end else if (!wr_win[SW]) begin
      mem_req_valid = 1'b1;
      mem_req_id = wr_win[SW-1:0];
      mem_req_write = 1'b1;
      mem_req_addr = entry_addr(sp_from[wr_win[SW-1:0]], wr_win[SW-1:0]);
      mem_req_bytes = 8'd8;
      mem_req_wdata = sp_ent[wr_win[SW-1:0]][0];
    end
  end
  wire mem_take = mem_req_valid && mem_req_ready;

  // ---- Units ----
  // A slot whose data arrives now may be granted now: its view of the data is the response.
  logic [MDW-1:0] view [SLOTS];
  logic [SLOTS-1:0] box_req, tri_req;
  logic [SLOTS*32-1:0] unit_ts;
  always_comb begin
    for (int k = 0; k < SLOTS; k++) begin
      logic arriving;
      arriving = mem_resp_valid && mem_resp_id == SW'(k) && st[k] == MEM && rd[k] != RD_ENTRY;
      view[k] = arriving ? mem_resp_data : data[k];
      box_req[k] = st[k] == BOX || (arriving && rd[k] == RD_NODE);
      tri_req[k] = st[k] == TRI || (arriving && rd[k] == RD_REC);
      unit_ts[32*k+:32] = arriving ? now : ts[k];
    end
  end
  logic [SW:0] box_win, tri_win;
  trav_oldest #(.SLOTS(SLOTS)) u_box_arb (.req(box_req), .t(unit_ts), .win(box_win));
  trav_oldest #(.SLOTS(SLOTS)) u_tri_arb (.req(tri_req), .t(unit_ts), .win(tri_win));

  logic box_in_ready, box_out_valid;
  /* verilator lint_off UNUSEDSIGNAL */  // the tags' bits above the slot index stay 0
  logic [15:0] box_out_tag;
  /* verilator lint_on UNUSEDSIGNAL */
  logic [N-1:0] box_out_hit;
  logic [N*NDW-1:0] box_out_tnear;
  logic [3*(A+1)-1:0] box_base;
  logic [3*SHW-1:0] box_sh;
  logic [6*N*K-1:0] box_q;
  logic [CW-1:0] box_count;
  logic [3*A-1:0] box_o;
  always_comb for (int a = 0; a < 3; a++) box_o[A*a+:A] = o[box_win[SW-1:0]][a];
  trav_decode #(
      .N(N), .K(K), .A(A), .F(F), .SHW(SHW), .MDW(MDW)
  ) u_decode (
      .node(view[box_win[SW-1:0]]), .org(box_o), .base(box_base), .sh(box_sh), .q(box_q), .count(box_count)
  );

  box_unit #(
      .N(N), .LANES(LANES), .K(K), .A(A), .M(M), .TB(TB), .SHW(SHW), .RSH(RSH), .LSH(LSH), .TAGW(16),
      .LATENCY(BOX_LAT)
  ) u_box (
      .clk(clk), .rst(rst),
      .in_valid(!box_win[SW]), .in_ready(box_in_ready), .in_tag(16'(box_win[SW-1:0])),
      .in_base(box_base), .in_sh(box_sh), .in_q(box_q), .in_count(box_count),
      .in_rcpm_dn(rcpm_dn[box_win[SW-1:0]]), .in_rcpm_up(rcpm_up[box_win[SW-1:0]]),
      .in_rcp_sh(rcp_sh[box_win[SW-1:0]]), .in_zero(zero[box_win[SW-1:0]]), .in_neg(neg[box_win[SW-1:0]]),
      .in_tmin(tmin[box_win[SW-1:0]]), .in_tlim(ct[box_win[SW-1:0]]),
      .out_valid(box_out_valid), .out_ready(1'b1), .out_tag(box_out_tag), .out_hit(box_out_hit),
      .out_tnear(box_out_tnear)
  );
  wire box_take = !box_win[SW] && box_in_ready;

  logic tri_in_ready, tri_out_valid, tri_out_hit;
  /* verilator lint_off UNUSEDSIGNAL */  // as box_out_tag
  logic [15:0] tri_out_tag;
  /* verilator lint_on UNUSEDSIGNAL */
  logic [TB:0] tri_out_t;
  logic [EW-1:0] tri_out_e1, tri_out_e2, tri_out_det;
  logic [9*B-1:0] tri_v;
  logic [3*A-1:0] tri_o;
  always_comb begin
    logic [SW-1:0] w;
    w = tri_win[SW-1:0];
    for (int i = 0; i < 9; i++) tri_v[B*i+:B] = view[w][32*i+:B];
    for (int a = 0; a < 3; a++) tri_o[A*a+:A] = o[w][a];
  end
  tri_core #(
      .B(B), .A(A), .F(F), .D(D), .TB(TB), .S(S), .TAGW(16), .LATENCY(TRI_LAT)
  ) u_tri (
      .clk(clk), .rst(rst),
      .in_valid(!tri_win[SW]), .in_ready(tri_in_ready), .in_tag(16'(tri_win[SW-1:0])),
      .in_v(tri_v), .in_o(tri_o), .in_d(dvec[tri_win[SW-1:0]]),
      .in_tmin(tmin[tri_win[SW-1:0]]), .in_tlim(ct[tri_win[SW-1:0]]),
      .out_valid(tri_out_valid), .out_ready(1'b1), .out_tag(tri_out_tag), .out_hit(tri_out_hit),
      .out_t(tri_out_t), .out_e1(tri_out_e1), .out_e2(tri_out_e2), .out_det(tri_out_det)
  );
  wire tri_take = !tri_win[SW] && tri_in_ready;

  // ---- Hit port and ray admission ----
  logic [SLOTS-1:0] wb_req, idle;
  logic [SLOTS*32-1:0] wb_ts;
  always_comb begin
    for (int k = 0; k < SLOTS; k++) begin
      wb_req[k] = st[k] == WB || want_wb[k];
      wb_ts[32*k+:32] = ts[k];
      idle[k] = st[k] == IDLE;
    end
  end
  logic [SW:0] wb_win, free_win;
  trav_oldest #(.SLOTS(SLOTS)) u_wb_arb (.req(wb_req), .t(wb_ts), .win(wb_win));
  trav_oldest #(.SLOTS(SLOTS)) u_free_arb (.req(idle), .t(wb_ts), .win(free_win));  // the slot free longest
  always_comb begin
    logic [SW-1:0] w;
    w = wb_win[SW-1:0];
    hit_valid = !wb_win[SW];
    hit_id = rid[w];
    hit_found = found[w];
    hit_t = ct[w];
    hit_prim = prim[w];
    hit_e1 = e1[w];
    hit_e2 = e2[w];
    hit_det = det[w];
  end
  wire hit_take = hit_valid && hit_ready;
  assign ray_ready = !free_win[SW];
  wire ray_take = ray_valid && ray_ready;
  always_comb begin
    busy = 1'b0;
    for (int k = 0; k < SLOTS; k++) busy = busy || st[k] != IDLE;
  end

  // ---- The box result: hit children sorted by distance (stable), the nearest next, the others pushed ----
  // Rank r (1..hits-1) goes to stack position depth + hits - 1 - r (the nearest of them on top); a position at
  // or beyond STACK is the pending spill boff = position - max(depth, STACK), below N - 1.
  logic [SW-1:0] bk;
  logic [CW-1:0] bhits;
  logic [CW-1:0] brank [N];
  logic [DEPW-1:0] bpos [N];
  /* verilator lint_off UNUSEDSIGNAL */  // boff < N - 1
  logic [DEPW-1:0] boff [N];
  /* verilator lint_on UNUSEDSIGNAL */
  always_comb begin
    bk = box_out_tag[SW-1:0];
    bhits = '0;
    for (int i = 0; i < N; i++) bhits = bhits + CW'(box_out_hit[i]);
    for (int i = 0; i < N; i++) begin
      brank[i] = '0;
      for (int j = 0; j < N; j++)
        if (box_out_hit[j] && ($signed(box_out_tnear[NDW*j+:NDW]) < $signed(box_out_tnear[NDW*i+:NDW]) ||
                               (box_out_tnear[NDW*j+:NDW] == box_out_tnear[NDW*i+:NDW] && j < i)))
          brank[i] = brank[i] + 1'b1;
      bpos[i] = depth[bk] + DEPW'(bhits) - 1'b1 - DEPW'(brank[i]);
      boff[i] = bpos[i] - (depth[bk] > DEPW'(STACK) ? depth[bk] : DEPW'(STACK));
    end
  end
  // The slot each event of this clock names: a new ray's, an issued read's, a response's, a triangle result's.
  wire [SW-1:0] nk = free_win[SW-1:0];
  wire [SW-1:0] mk = mem_req_id;
  wire [SW-1:0] rk = mem_resp_id;
  wire [SW-1:0] tk = tri_out_tag[SW-1:0];
  wire signed [NDW-1:0] edist = $signed(mem_resp_data[32+:NDW]);  // a read-back entry's distance

  always_ff @(posedge clk) begin
    if (rst) begin
      now <= '0;
      for (int k = 0; k < SLOTS; k++) begin
        st[k] <= IDLE;
        ts[k] <= '0;
        sp_n[k] <= '0;
      end
    end else begin
      now <= now + 1'b1;
      for (int k = 0; k < SLOTS; k++) begin
        // Countdown to the next action.
        if (st[k] == ACT && cnt[k] != 0) begin
          cnt[k] <= cnt[k] - 1'b1;
        end
        // A spill written.
        if (mem_take && mem_req_write && mem_req_id == SW'(k)) begin
          sp_from[k] <= sp_from[k] + 1'b1;
          sp_n[k] <= sp_n[k] - 1'b1;
          for (int j = 0; j + 1 < N; j++) sp_ent[k][j] <= sp_ent[k][j+1];
        end
      end
      // A new ray.
      if (ray_take) begin
        st[nk] <= ACT;
        cnt[nk] <= CNTW'(SETUP_LAT - 1);
        ts[nk] <= now + 32'(SETUP_LAT) - 32'd1;
        rid[nk] <= ray_id;
        any_hit[nk] <= ray_any_hit;
        for (int a = 0; a < 3; a++) o[nk][a] <= ray_o[A*a+:A];
        dvec[nk] <= ray_d;
        rcpm_dn[nk] <= ray_rcpm_dn;
        rcpm_up[nk] <= ray_rcpm_up;
        rcp_sh[nk] <= ray_rcp_sh;
        zero[nk] <= ray_zero;
        neg[nk] <= ray_neg;
        tmin[nk] <= ray_tmin;
        ct[nk] <= ray_tmax;
        found[nk] <= 1'b0;
        prim[nk] <= '0;
        e1[nk] <= '0;
        e2[nk] <= '0;
        det[nk] <= '0;
        have_cur[nk] <= 1'b1;
        cur[nk] <= cfg_root;
        rec_left[nk] <= '0;
        done[nk] <= 1'b0;
        depth[nk] <= '0;
        sp_n[nk] <= '0;
      end
      // A read issued: the pop it made, the leaf it starts.
      if (mem_take && !mem_req_write) begin
        st[mk] <= MEM;
        rd[mk] <= act_rd[mk];
        if (act_pop[mk]) depth[mk] <= act_depth[mk];
        if (act_rd[mk] == RD_ENTRY) depth[mk] <= depth[mk] - 1'b1;
        if (act_rd[mk] != RD_ENTRY && rec_left[mk] == 0) begin
          have_cur[mk] <= 1'b0;
          if (act_ref[mk][31]) begin  // a leaf: its records from the first
            rec_idx[mk] <= {5'b0, act_ref[mk][26:0]};
            rec_left[mk] <= 5'(act_ref[mk][30:27]) + 1'b1;
          end
        end
      end
      // The write-back taken, or an empty stack found.
      for (int k = 0; k < SLOTS; k++) begin
        if (want_wb[k] && !(hit_take && wb_win[SW-1:0] == SW'(k))) begin
          st[k] <= WB;
          ts[k] <= now;
          if (act_pop[k]) depth[k] <= '0;
        end
      end
      if (hit_take) begin
        st[wb_win[SW-1:0]] <= IDLE;
        ts[wb_win[SW-1:0]] <= now;  // free since
      end
      // Data arrives: kept; an entry read back is popped or dropped.
      if (mem_resp_valid) begin
        if (rd[rk] == RD_ENTRY) begin
          st[rk] <= ACT;
          cnt[rk] <= '0;
          ts[rk] <= now + 1'b1;
          if (!($signed({ct[rk][TB], ct[rk]}) < edist)) begin
            have_cur[rk] <= 1'b1;
            cur[rk] <= mem_resp_data[31:0];
          end
        end else begin
          data[rk] <= mem_resp_data;
          st[rk] <= rd[rk] == RD_NODE ? BOX : TRI;
          ts[rk] <= now;
        end
      end
      if (box_take) st[box_win[SW-1:0]] <= UNIT;
      if (tri_take) st[tri_win[SW-1:0]] <= UNIT;
      // A node's result.
      // A unit's result: the slot's next step TRAV_LAT clocks on.
      for (int k = 0; k < SLOTS; k++)
        if ((box_out_valid && bk == SW'(k)) || (tri_out_valid && tri_out_tag[SW-1:0] == SW'(k))) begin
          st[k] <= ACT;
          cnt[k] <= CNTW'(TRAV_LAT - 1);
          ts[k] <= now + 32'(TRAV_LAT) - 32'd1;
        end
      if (box_out_valid) begin
        have_cur[bk] <= bhits != 0;
        for (int i = 0; i < N; i++)
          if (box_out_hit[i]) begin
            if (brank[i] == 0) cur[bk] <= word(data[bk], 16 + 6 * N + 4 * i);
            else begin
              if (bpos[i] < DEPW'(STACK)) begin
                sref[bk][bpos[i][STW-1:0]] <= word(data[bk], 16 + 6 * N + 4 * i);
                sdist[bk][bpos[i][STW-1:0]] <= $signed(box_out_tnear[NDW*i+:NDW]);
              end else begin
                sp_ent[bk][boff[i][SPW-1:0]] <=
                    {box_out_tnear[NDW*i+:NDW], word(data[bk], 16 + 6 * N + 4 * i)};
              end
            end
          end
        if (bhits > 1) begin
          depth[bk] <= depth[bk] + DEPW'(bhits) - 1'b1;
          if (depth[bk] + DEPW'(bhits) - 1'b1 > DEPW'(STACK)) begin
            sp_from[bk] <= depth[bk] > DEPW'(STACK) ? depth[bk] : DEPW'(STACK);
            sp_n[bk] <= 4'(depth[bk] + DEPW'(bhits) - 1'b1 - (depth[bk] > DEPW'(STACK) ? depth[bk] : DEPW'(STACK)));
          end
        end
      end
      // A triangle's result.
      if (tri_out_valid) begin
        rec_idx[tk] <= rec_idx[tk] + 1'b1;
        rec_left[tk] <= rec_left[tk] - 1'b1;
        if (tri_out_hit) begin
          found[tk] <= 1'b1;
          ct[tk] <= tri_out_t;
          prim[tk] <= word(data[tk], 36);
          e1[tk] <= tri_out_e1;
          e2[tk] <= tri_out_e2;
          det[tk] <= tri_out_det;
          if (any_hit[tk]) begin
            done[tk] <= 1'b1;
            rec_left[tk] <= '0;
          end
        end
      end
    end
  end
endmodule
