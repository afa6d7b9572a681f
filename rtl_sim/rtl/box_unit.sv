// box_unit: the ray-box test unit of the fixed-point device. It takes one BVH node of N child boxes and one ray,
// and answers per child: hit over [tmin, tlim] and the entry distance t_near. The arithmetic is box_core.sv's
// (exactly hw::box_test_delta<int64_t>; widths, rounding and pipeline documented there).
//
// LANES box tests per clock (1 <= LANES <= N): box_core is instantiated LANES wide and a node's occupied children
// go through it LANES at a time, in ceil(count / LANES) clocks (one clock when count = 0). This is the timing
// model's box unit with box_rate = LANES and box_latency = LATENCY (hwmodel/timing/timing_config.h, timing_model.h: a
// node of `count` children issues in ceil(count / box_rate) clocks and its result leaves box_latency + issue - 1
// clocks after it was taken). With LANES = N the sequencer is not built: box_unit is box_core.
//
// Handshake (valid/ready): a node is taken at a rising edge with in_valid && in_ready; its result leaves at a
// rising edge with out_valid && out_ready, in order, outputs held while stalled. in_ready is low while the
// sequencer feeds a node's later chunks (it holds the node in registers): a node taken at edge c keeps the input
// busy through edge c + chunks - 1 and, with out_ready high, leaves at edge c + chunks - 1 + LATENCY.
// Slots i >= count never hit (their t_near outputs mean nothing).
module box_unit #(
    parameter int N       = 4,   // child boxes per node (BVH width)
    parameter int LANES   = 4,   // box tests per clock (1..N)
    parameter int K       = 8,   // child offset bits (FixedFormat::child_bits)
    parameter int A       = 39,  // translated-delta magnitude bits (B+G+F+1)
    parameter int M       = 21,  // reciprocal mantissa significant bits (rcp_bits + 1)
    parameter int TB      = 56,  // t magnitude bits (t_bits)
    parameter int SHW     = 6,   // width of the node shift sh = exp + F
    parameter int RSH     = 12,  // largest right shift of a product, F+R-T
    parameter int LSH     = 12,  // largest left shift of a product, max(0, D-(F+R-T))
    parameter int TAGW    = 16,  // user tag carried with each node
    parameter int LATENCY = 6,   // box_core pipeline depth in clocks (>= 1)
    localparam int CW     = $clog2(N + 1),
    localparam int RSW    = $clog2((LSH > RSH ? LSH : RSH) + 1) + 1
) (
    input logic clk,
    input logic rst,  // synchronous, active high: empties the pipeline and the sequencer

    input  logic                  in_valid,
    output logic                  in_ready,
    input  logic [      TAGW-1:0] in_tag,
    input  logic [   3*(A+1)-1:0] in_base,
    input  logic [     3*SHW-1:0] in_sh,
    input  logic [   6*N*K-1:0]   in_q,        // row r (lo_x, hi_x, lo_y, hi_y, lo_z, hi_z), slot i at (r*N+i)*K
    input  logic [      CW-1:0]   in_count,
    input  logic [   3*(M+2)-1:0] in_rcpm_dn,
    input  logic [   3*(M+2)-1:0] in_rcpm_up,
    input  logic [     3*RSW-1:0] in_rcp_sh,
    input  logic [           2:0] in_zero,
    input  logic [           2:0] in_neg,
    input  logic [          TB:0] in_tmin,
    input  logic [          TB:0] in_tlim,

    output logic                  out_valid,
    input  logic                  out_ready,
    output logic [      TAGW-1:0] out_tag,
    output logic [         N-1:0] out_hit,
    output logic [N*(TB+2)-1:0]   out_tnear
);
  initial begin
    if (LANES < 1 || LANES > N) $error("box_unit: LANES must be in 1..N");
  end

  if (LANES == N) begin : g_full
    box_core #(
        .N(N), .K(K), .A(A), .M(M), .TB(TB), .SHW(SHW), .RSH(RSH), .LSH(LSH), .TAGW(TAGW), .LATENCY(LATENCY)
    ) u_core (
        .clk, .rst, .in_valid, .in_ready, .in_tag, .in_base, .in_sh, .in_q, .in_count, .in_rcpm_dn, .in_rcpm_up,
        .in_rcp_sh, .in_zero, .in_neg, .in_tmin, .in_tlim, .out_valid, .out_ready, .out_tag, .out_hit, .out_tnear
    );
  end else begin : g_seq
    localparam int CH = (N + LANES - 1) / LANES;  // chunks of a full node
    localparam int JW = CH > 1 ? $clog2(CH) : 1;  // chunk index width
    localparam int LCW = $clog2(LANES + 1);  // box_core's count width
    localparam int TW = TB + 2;
    localparam int CTAGW = TAGW + JW + 1;  // box_core's tag: {user tag, chunk index, last chunk}

    // ---- input side: the node in hold registers while its later chunks go in ------------------------------
    logic busy;  // a node's chunk j (>= 1) is next
    logic [JW-1:0] j;
    logic [TAGW-1:0] h_tag;
    logic [3*(A+1)-1:0] h_base;
    logic [3*SHW-1:0] h_sh;
    logic [6*N*K-1:0] h_q;
    logic [CW-1:0] h_count;
    logic [3*(M+2)-1:0] h_rcpm_dn, h_rcpm_up;
    logic [3*RSW-1:0] h_rcp_sh;
    logic [2:0] h_zero, h_neg;
    logic [TB:0] h_tmin, h_tlim;

    // The node the core sees this clock (the input when idle, else the held node) and its chunk.
    logic [TAGW-1:0] c_tag;
    logic [3*(A+1)-1:0] c_base;
    logic [3*SHW-1:0] c_sh;
    logic [6*N*K-1:0] c_q;
    logic [CW-1:0] c_count;
    logic [3*(M+2)-1:0] c_rcpm_dn, c_rcpm_up;
    logic [3*RSW-1:0] c_rcp_sh;
    logic [2:0] c_zero, c_neg;
    logic [TB:0] c_tmin, c_tlim;
    logic [JW-1:0] cj;
    assign {c_tag, c_base, c_sh, c_q, c_count, c_rcpm_dn, c_rcpm_up, c_rcp_sh, c_zero, c_neg, c_tmin, c_tlim} =
        busy ? {h_tag, h_base, h_sh, h_q, h_count, h_rcpm_dn, h_rcpm_up, h_rcp_sh, h_zero, h_neg, h_tmin, h_tlim}
             : {in_tag, in_base, in_sh, in_q, in_count, in_rcpm_dn, in_rcpm_up, in_rcp_sh, in_zero, in_neg,
                in_tmin, in_tlim};
    assign cj = busy ? j : '0;

    // Chunk cj's slots: q columns cj*LANES .. cj*LANES+LANES-1 (zero beyond N), its occupied count, last chunk.
    logic [6*LANES*K-1:0] k_q;
    logic [LCW-1:0] k_count;
    logic k_last;
    always_comb begin
      k_q = '0;
      k_count = '0;
      k_last = 1'b0;
      for (int c = 0; c < CH; c++) begin
        if (JW'(c) == cj) begin
          for (int r = 0; r < 6; r++)
            for (int i = 0; i < LANES; i++)
              if (c * LANES + i < N) k_q[(r*LANES+i)*K+:K] = c_q[(r*N+c*LANES+i)*K+:K];
          // Occupied slots of this chunk: clamp(count - c*LANES, 0, LANES); the last chunk holds slot count-1
          // (chunk 0 when count = 0).
          if (32'(c_count) >= 32'((c + 1) * LANES)) k_count = LCW'(LANES);
          else if (32'(c_count) > 32'(c * LANES)) k_count = LCW'(32'(c_count) - 32'(c * LANES));
          k_last = 32'(c_count) <= 32'((c + 1) * LANES);
        end
      end
    end

    logic core_in_valid, core_in_ready;
    assign core_in_valid = busy | in_valid;
    assign in_ready = ~busy & core_in_ready;

    always_ff @(posedge clk) begin
      if (rst) begin
        busy <= 1'b0;
        j <= '0;
      end else if (core_in_valid && core_in_ready) begin
        if (k_last) begin
          busy <= 1'b0;
          j <= '0;
        end else begin
          busy <= 1'b1;
          j <= cj + JW'(1);
        end
      end
    end
    always_ff @(posedge clk) begin
      if (!busy && in_valid && core_in_ready) begin  // a node taken: hold it for its later chunks
        {h_tag, h_base, h_sh, h_q, h_count, h_rcpm_dn, h_rcpm_up, h_rcp_sh, h_zero, h_neg, h_tmin, h_tlim} <=
            {in_tag, in_base, in_sh, in_q, in_count, in_rcpm_dn, in_rcpm_up, in_rcp_sh, in_zero, in_neg, in_tmin,
             in_tlim};
      end
    end

    // ---- the core, LANES wide ------------------------------------------------------------------------------
    logic core_out_valid, core_out_ready;
    logic [CTAGW-1:0] core_out_tag;
    logic [LANES-1:0] core_out_hit;
    logic [LANES*TW-1:0] core_out_tnear;
    box_core #(
        .N(LANES), .K(K), .A(A), .M(M), .TB(TB), .SHW(SHW), .RSH(RSH), .LSH(LSH), .TAGW(CTAGW), .LATENCY(LATENCY)
    ) u_core (
        .clk, .rst,
        .in_valid(core_in_valid), .in_ready(core_in_ready), .in_tag({c_tag, cj, k_last}), .in_base(c_base),
        .in_sh(c_sh), .in_q(k_q), .in_count(k_count), .in_rcpm_dn(c_rcpm_dn), .in_rcpm_up(c_rcpm_up),
        .in_rcp_sh(c_rcp_sh), .in_zero(c_zero), .in_neg(c_neg), .in_tmin(c_tmin), .in_tlim(c_tlim),
        .out_valid(core_out_valid), .out_ready(core_out_ready), .out_tag(core_out_tag), .out_hit(core_out_hit),
        .out_tnear(core_out_tnear)
    );

    // ---- output side: earlier chunks collect in registers, the last one completes the node -----------------
    logic [TAGW-1:0] o_tag;
    logic [JW-1:0] oj;
    logic o_last;
    assign {o_tag, oj, o_last} = core_out_tag;
    // An earlier chunk is always taken (the node's last chunk, behind it, is what waits for out_ready).
    assign core_out_ready = o_last ? out_ready : 1'b1;
    assign out_valid = core_out_valid & o_last;
    assign out_tag = o_tag;

    logic [N-1:0] acc_hit;
    logic [N*TW-1:0] acc_t;
    always_ff @(posedge clk) begin
      if (core_out_valid && !o_last) begin
        for (int c = 0; c < CH; c++)
          if (JW'(c) == oj)
            for (int i = 0; i < LANES; i++)
              if (c * LANES + i < N) begin
                acc_hit[c*LANES+i] <= core_out_hit[i];
                acc_t[(c*LANES+i)*TW+:TW] <= core_out_tnear[i*TW+:TW];
              end
      end
    end
    // Slots of chunks before the last come from the registers, the last chunk's from the core, later ones
    // (unoccupied) are 0.
    always_comb begin
      out_hit = '0;
      out_tnear = '0;
      for (int c = 0; c < CH; c++)
        for (int i = 0; i < LANES; i++)
          if (c * LANES + i < N) begin
            if (JW'(c) < oj) begin
              out_hit[c*LANES+i] = acc_hit[c*LANES+i];
              out_tnear[(c*LANES+i)*TW+:TW] = acc_t[(c*LANES+i)*TW+:TW];
            end else if (JW'(c) == oj) begin
              out_hit[c*LANES+i] = core_out_hit[i];
              out_tnear[(c*LANES+i)*TW+:TW] = core_out_tnear[i*TW+:TW];
            end
          end
    end
  end
endmodule
