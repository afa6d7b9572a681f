// box_core: the ray-box test datapath of the fixed-point device, fully pipelined, N child boxes per clock (box_unit.sv
// instantiates it with N = its LANES and feeds it a node's children LANES at a time). It computes exactly hw::box_test_delta<int64_t> (hwmodel/datapath/intersect_fixed.h, the 64-bit path of a
// "narrow" format such as the default one) for every child, with the node decoded as the fixed tracer decodes it
// (hwmodel/datapath/fixed_tracer.cpp, FixedPolicy::expand_impl):
//   dl[a] = base[a] + (q[2a][i] << sh[a]),  dh[a] = base[a] + (q[2a+1][i] << sh[a])       (grid.F)
//   base[a] = (node origin[a] << F) - ray origin[a],  sh[a] = node exp[a] + F
// then per axis a with d[a] != 0 (dn/df = near/far plane by the direction's sign):
//   mn = dn >= 0 ? rcpm_dn : rcpm_up,  mf = df >= 0 ? rcpm_up : rcpm_dn
//   tn = floor(dn * mn / 2^rcp_sh),    tf = ceil(df * mf / 2^rcp_sh)   (a left shift when rcp_sh < 0)
// and for axes with d[a] == 0 the slab test dl <= 0 <= dh instead; t0 = max(tmin, tn...), t1 = min(tlim, tf...),
// hit = t0 <= t1 (and the slot is occupied, i < count); t_near = t0.
//
// Widths (parameters; rtl_sim/params/rtl_params.h derives them from a FixedFormat, signed values carry one sign bit
// more than their magnitude bits):
//   base, dl, dh      A+1 bits signed, |x| < 2^A, A = B+G+F+1 (FixedFormat::translated_bits)
//   rcpm_dn/up        M+2 bits signed, |m| <= 2^M, M = rcp_bits + 1 (the mantissa's significant bits)
//   products          PW = A+M+1 bits signed (|p| < 2^(A+M); A+M+1 <= 63 is the format's "narrow" condition)
//   rcp_sh            signed, in [-LSH, RSH]: RSH = F+R-T, LSH = max(0, D-RSH)
//   tmin, tlim        TB+1 bits signed, |t| <= 2^TB - 1 (TB = t_bits)
//   tn, tf, t_near    TB+2 bits signed: the C++ values saturated to +-2^TB. The C++ clamps products at +-2^62 (or
//                     not at all on the 64-bit right-shift path); saturating at +-2^TB instead is monotone and
//                     leaves every value in the t register alone, so t0 <= t1 decides the same and t_near equals
//                     the C++ t0 whenever the box is hit (the traversal uses t_near only then; on a miss it is
//                     the C++ t0 saturated to +-2^TB).
// Contract: the inputs are those of a valid node and ray (|dl|, |dh| < 2^A, |rcpm| <= 2^M, rcp_sh in range,
// count <= N, |tmin|, |tlim| < 2^TB); the fields of zero axes other than zero[a] are ignored. Slots i >= count are
// computed but never hit. Per-axis and per-slot fields are packed into flat ports (axis a of a W-bit field at
// [a*W +: W]), which every tool reads (yosys 0.23 reads no multi-dimensional packed ports).
//
// Pipeline: four steps, each followed by D1..D4 registers, D1 + D2 + D3 + D4 = LATENCY (>= 1):
//   1 decode: 6N shift-adds (child planes minus origin), near/far and mantissa selects, zero-axis slab test,
//     occupancy mask                                                                    D1 = 1 if LATENCY >= 4
//   2 multiply: 6N signed (A+1) x (M+2) products                                        D2 = LATENCY - 3 if
//     (the extra registers of a deeper LATENCY sit here, for retiming into the             LATENCY >= 4, else 1
//     multipliers)                                                                         if LATENCY >= 2
//   3 shift: one bidirectional shifter per product (p << LSH, then >> rcp_sh + LSH with
//     floor or ceil), saturation to +-2^TB, neutral values for zero axes               D3 = 1 if LATENCY >= 3
//   4 reduce: t0 = max of 4, t1 = min of 4, compare, hit mask                           D4 = 1
// (LATENCY = 6, the rdna2 preset's box_latency: D = 1, 3, 1, 1.)
//
// Handshake (valid/ready, AXI-stream style): an input is taken at a rising edge with in_valid && in_ready, a
// result leaves at a rising edge with out_valid && out_ready. While out_valid && !out_ready the outputs hold.
// Every stage has a valid bit and loads when it is empty or its successor loads, so a stall holds every item
// in place (nothing lost, nothing duplicated) and bubbles are squeezed out while the output waits:
//   in_ready = out_ready || some stage is empty.
// The only combinational path from an output-side port to an input-side port is out_ready -> in_ready.
//
// Latency and throughput: a node taken at edge c leaves at edge c + LATENCY when out_ready is high (its
// out_valid rises after edge c + LATENCY - 1). With out_ready high, in_ready stays high: one node (N box tests)
// per clock, and M back-to-back nodes taken from edge 0 on leave at edges LATENCY .. M - 1 + LATENCY, i.e.
// M + LATENCY - 1 edges from the first taken to the last leaving. This is the timing model's box unit with
// box_rate >= N and box_latency = LATENCY (hwmodel/timing/timing_config.h: a node issues in one clock, its result
// comes box_latency later).
module box_core #(
    parameter int N       = 4,   // child boxes per node (BVH width)
    parameter int K       = 8,   // child offset bits (FixedFormat::child_bits)
    parameter int A       = 39,  // translated-delta magnitude bits (B+G+F+1)
    parameter int M       = 21,  // reciprocal mantissa significant bits (rcp_bits + 1)
    parameter int TB      = 56,  // t magnitude bits (t_bits)
    parameter int SHW     = 6,   // width of the node shift sh = exp + F (unsigned, up to B+1+F)
    parameter int RSH     = 12,  // largest right shift of a product, F+R-T
    parameter int LSH     = 12,  // largest left shift of a product, max(0, D-(F+R-T))
    parameter int TAGW    = 16,  // user tag carried with each node (e.g. the ray slot)
    parameter int LATENCY = 6,   // pipeline depth in clocks (>= 1)
    localparam int CW     = $clog2(N + 1),                           // child count width
    localparam int RSW    = $clog2((LSH > RSH ? LSH : RSH) + 1) + 1  // signed rcp_sh width
) (
    input logic clk,
    input logic rst,  // synchronous, active high: empties the pipeline

    input  logic                  in_valid,
    output logic                  in_ready,
    input  logic [      TAGW-1:0] in_tag,
    // node (per-axis fields packed with axis a at bits [a*W +: W])
    input  logic [   3*(A+1)-1:0] in_base,     // signed, per axis
    input  logic [     3*SHW-1:0] in_sh,       // per axis
    input  logic [   6*N*K-1:0]   in_q,        // row r (lo_x, hi_x, lo_y, hi_y, lo_z, hi_z), slot i at (r*N+i)*K
    input  logic [      CW-1:0]   in_count,    // occupied slots (they come first)
    // ray
    input  logic [   3*(M+2)-1:0] in_rcpm_dn,  // signed, per axis
    input  logic [   3*(M+2)-1:0] in_rcpm_up,  // signed, per axis
    input  logic [     3*RSW-1:0] in_rcp_sh,   // signed, per axis
    input  logic [           2:0] in_zero,     // d[a] == 0
    input  logic [           2:0] in_neg,      // d[a] < 0
    input  logic [          TB:0] in_tmin,     // signed
    input  logic [          TB:0] in_tlim,     // signed: the current closest hit (or tmax)

    output logic                  out_valid,
    input  logic                  out_ready,
    output logic [      TAGW-1:0] out_tag,
    output logic [         N-1:0] out_hit,
    output logic [N*(TB+2)-1:0]   out_tnear    // signed, slot i at [i*(TB+2) +: TB+2]
);
  localparam int PW = A + M + 1;  // product width
  localparam int XW = (PW + LSH + 1 > TB + 2) ? PW + LSH + 1 : TB + 2;  // shifter width
  localparam int KW = $clog2(LSH + RSH + 1) > 0 ? $clog2(LSH + RSH + 1) : 1;  // shift amount width
  localparam logic signed [XW-1:0] TSAT = XW'(1) << TB;  // saturation bound 2^TB
  localparam logic signed [TB+1:0] TPOS = (TB + 2)'(1) << TB;  // +2^TB, neutral for the min
  localparam logic signed [TB+1:0] TNEG = -TPOS;  // -2^TB, neutral for the max
  localparam int DW = A + 1, MW = M + 2, TW = TB + 2;  // widths of a delta, a mantissa, a saturated t

  // Registers after each step (see the header).
  localparam int D1 = LATENCY >= 4 ? 1 : 0;
  localparam int D2 = LATENCY >= 4 ? LATENCY - 3 : (LATENCY >= 2 ? 1 : 0);
  localparam int D3 = LATENCY >= 3 ? 1 : 0;
  localparam int D4 = 1;
  localparam int O2 = D1, O3 = D1 + D2, O4 = D1 + D2 + D3;  // stages before each step's registers

  initial begin
    if (LATENCY < 1) $error("box_core: LATENCY must be >= 1");
    if (D1 + D2 + D3 + D4 != LATENCY) $error("box_core: stage split does not add up to LATENCY");
    if (PW > 63) $error("box_core: A + M + 1 > 63: not a narrow format (64-bit products)");
  end

  // ---- handshake: valid bit per stage, load enables --------------------------------------------------------
  logic [LATENCY:1] vs;  // stage s holds an item
  logic [LATENCY:0] vin;  // vin[s] = what stage s + 1 would take: vin[0] = in_valid
  logic [LATENCY:1] en;  // stage s takes the item before it (or a bubble) at this edge
  logic [LATENCY:1] ld;  // ... and that is an item: its data registers load
  assign vin = {vs, in_valid};
  for (genvar s = 1; s <= LATENCY; s++) begin : g_en
    assign en[s] = out_ready | ~(&vs[LATENCY:s]);
    assign ld[s] = en[s] & vin[s-1];
  end
  always_ff @(posedge clk) begin
    if (rst) vs <= '0;
    else for (int s = 1; s <= LATENCY; s++) if (en[s]) vs[s] <= vin[s-1];
  end
  assign in_ready  = en[1];
  assign out_valid = vs[LATENCY];

  // Per-child, per-axis values are packed flat: child i, axis a at index j = 3 * i + a.

  // ---- step 1: decode ---------------------------------------------------------------------------------------
  logic [3*N*DW-1:0] s1_dn, s1_df;  // near/far plane minus origin, signed
  logic [3*N*MW-1:0] s1_mn, s1_mf;  // the reciprocal mantissa for each, signed
  logic [N-1:0] s1_en;  // occupied and inside every zero-direction slab
  for (genvar i = 0; i < N; i++) begin : g_dec
    logic [2:0] zmiss;
    for (genvar a = 0; a < 3; a++) begin : g_axis
      localparam int J = 3 * i + a;
      logic [A:0] offl, offh;  // q << sh: < 2^A for a valid node
      logic signed [A:0] dl, dh, dn, df;
      assign offl = (A + 1)'(in_q[(2*a*N+i)*K+:K]) << in_sh[a*SHW+:SHW];
      assign offh = (A + 1)'(in_q[((2*a+1)*N+i)*K+:K]) << in_sh[a*SHW+:SHW];
      assign dl = $signed(in_base[a*DW+:DW]) + $signed(offl);
      assign dh = $signed(in_base[a*DW+:DW]) + $signed(offh);
      assign dn = in_neg[a] ? dh : dl;
      assign df = in_neg[a] ? dl : dh;
      assign s1_dn[J*DW+:DW] = dn;
      assign s1_df[J*DW+:DW] = df;
      assign s1_mn[J*MW+:MW] = dn[A] ? in_rcpm_up[a*MW+:MW] : in_rcpm_dn[a*MW+:MW];
      assign s1_mf[J*MW+:MW] = df[A] ? in_rcpm_dn[a*MW+:MW] : in_rcpm_up[a*MW+:MW];
      assign zmiss[a] = in_zero[a] & ((~dl[A] & (|dl)) | dh[A]);  // dl > 0 || dh < 0
    end
    assign s1_en[i] = (CW'(i) < in_count) & ~(|zmiss);
  end

  localparam int W1 = 2 * 3 * N * DW + 2 * 3 * N * MW + 3 * RSW + 3 + N + 2 * (TB + 1) + TAGW;
  logic [W1-1:0] b1_d, b1_q;
  assign b1_d = {s1_dn, s1_df, s1_mn, s1_mf, in_rcp_sh, in_zero, s1_en, in_tmin, in_tlim, in_tag};
  if (D1 > 0) begin : g_r1
    pipe_delay #(.W(W1), .DEPTH(D1)) u_r (.clk, .load(ld[D1:1]), .d(b1_d), .q(b1_q));
  end else begin : g_w1
    assign b1_q = b1_d;
  end

  // ---- step 2: multiply -------------------------------------------------------------------------------------
  logic [3*N*DW-1:0] s2_dn, s2_df;
  logic [3*N*MW-1:0] s2_mn, s2_mf;
  logic [3*RSW-1:0] s2_rsh;
  logic [2:0] s2_zero;
  logic [N-1:0] s2_en;
  logic [TB:0] s2_tmin, s2_tlim;
  logic [TAGW-1:0] s2_tag;
  assign {s2_dn, s2_df, s2_mn, s2_mf, s2_rsh, s2_zero, s2_en, s2_tmin, s2_tlim, s2_tag} = b1_q;

  logic [3*N*PW-1:0] s2_pn, s2_pf;  // signed products, exact in PW bits
  for (genvar j = 0; j < 3 * N; j++) begin : g_mul
    assign s2_pn[j*PW+:PW] = $signed(PW'($signed(s2_dn[j*DW+:DW]))) * $signed(PW'($signed(s2_mn[j*MW+:MW])));
    assign s2_pf[j*PW+:PW] = $signed(PW'($signed(s2_df[j*DW+:DW]))) * $signed(PW'($signed(s2_mf[j*MW+:MW])));
  end

  localparam int W2 = 2 * 3 * N * PW + 3 * RSW + 3 + N + 2 * (TB + 1) + TAGW;
  logic [W2-1:0] b2_d, b2_q;
  assign b2_d = {s2_pn, s2_pf, s2_rsh, s2_zero, s2_en, s2_tmin, s2_tlim, s2_tag};
  if (D2 > 0) begin : g_r2
    pipe_delay #(.W(W2), .DEPTH(D2)) u_r (.clk, .load(ld[O2+D2:O2+1]), .d(b2_d), .q(b2_q));
  end else begin : g_w2
    assign b2_q = b2_d;
  end

  // ---- step 3: shift, round, saturate ---------------------------------------------------------------------
  logic [3*N*PW-1:0] s3_pn, s3_pf;
  logic [3*RSW-1:0] s3_rsh;
  logic [2:0] s3_zero;
  logic [N-1:0] s3_en;
  logic [TB:0] s3_tmin, s3_tlim;
  logic [TAGW-1:0] s3_tag;
  assign {s3_pn, s3_pf, s3_rsh, s3_zero, s3_en, s3_tmin, s3_tlim, s3_tag} = b2_q;

  logic [3*N*TW-1:0] s3_tn, s3_tf;  // signed, saturated to +-2^TB
  for (genvar a = 0; a < 3; a++) begin : g_sh
    // p * 2^-rcp_sh = (p << LSH) >> (rcp_sh + LSH): one right shifter; the low LSH bits of p << LSH are zero,
    // so rounding up adds nothing when rcp_sh < 0 and the left shift stays exact.
    logic [KW-1:0] k;
    logic signed [XW-1:0] bias;  // 2^k - 1
    assign k = KW'($signed(s3_rsh[a*RSW+:RSW]) + $signed(RSW'(LSH)));
    assign bias = $signed(~({XW{1'b1}} << k));
    for (genvar i = 0; i < N; i++) begin : g_child
      localparam int J = 3 * i + a;
      logic signed [XW-1:0] xn, xf, yn, yf, sf;
      assign xn = $signed(XW'($signed(s3_pn[J*PW+:PW]))) <<< LSH;
      assign xf = $signed(XW'($signed(s3_pf[J*PW+:PW]))) <<< LSH;
      assign sf = xf + bias;
      assign yn = xn >>> k;  // floor
      assign yf = sf >>> k;  // ceil
      assign s3_tn[J*TW+:TW] = s3_zero[a] ? TNEG : (yn > TSAT ? TPOS : (yn < -TSAT ? TNEG : yn[TW-1:0]));
      assign s3_tf[J*TW+:TW] = s3_zero[a] ? TPOS : (yf > TSAT ? TPOS : (yf < -TSAT ? TNEG : yf[TW-1:0]));
    end
  end

  localparam int W3 = 2 * 3 * N * TW + N + 2 * (TB + 1) + TAGW;
  logic [W3-1:0] b3_d, b3_q;
  assign b3_d = {s3_tn, s3_tf, s3_en, s3_tmin, s3_tlim, s3_tag};
  if (D3 > 0) begin : g_r3
    pipe_delay #(.W(W3), .DEPTH(D3)) u_r (.clk, .load(ld[O3+D3:O3+1]), .d(b3_d), .q(b3_q));
  end else begin : g_w3
    assign b3_q = b3_d;
  end

  // ---- step 4: reduce ---------------------------------------------------------------------------------------
  logic [3*N*TW-1:0] s4_tn, s4_tf;
  logic [N-1:0] s4_en;
  logic [TB:0] s4_tmin, s4_tlim;
  logic [TAGW-1:0] s4_tag;
  assign {s4_tn, s4_tf, s4_en, s4_tmin, s4_tlim, s4_tag} = b3_q;

  logic [N-1:0] s4_hit;
  logic [N*TW-1:0] s4_t0;
  for (genvar i = 0; i < N; i++) begin : g_red
    logic signed [TW-1:0] tn0, tn1, tn2, tf0, tf1, tf2, n0, n1, n2, f0, f1, f2, lo, hi;
    assign tn0 = s4_tn[(3*i)*TW+:TW];
    assign tn1 = s4_tn[(3*i+1)*TW+:TW];
    assign tn2 = s4_tn[(3*i+2)*TW+:TW];
    assign tf0 = s4_tf[(3*i)*TW+:TW];
    assign tf1 = s4_tf[(3*i+1)*TW+:TW];
    assign tf2 = s4_tf[(3*i+2)*TW+:TW];
    assign lo = {s4_tmin[TB], s4_tmin};
    assign hi = {s4_tlim[TB], s4_tlim};
    assign n0 = tn0 > lo ? tn0 : lo;
    assign n1 = tn1 > n0 ? tn1 : n0;
    assign n2 = tn2 > n1 ? tn2 : n1;
    assign f0 = tf0 < hi ? tf0 : hi;
    assign f1 = tf1 < f0 ? tf1 : f0;
    assign f2 = tf2 < f1 ? tf2 : f1;
    assign s4_t0[i*TW+:TW] = n2;
    assign s4_hit[i] = s4_en[i] & (n2 <= f2);
  end

  localparam int W4 = N + N * TW + TAGW;
  logic [W4-1:0] b4_d, b4_q;
  assign b4_d = {s4_hit, s4_t0, s4_tag};
  pipe_delay #(.W(W4), .DEPTH(D4)) u_r4 (.clk, .load(ld[O4+D4:O4+1]), .d(b4_d), .q(b4_q));
  assign {out_hit, out_tnear, out_tag} = b4_q;
endmodule
