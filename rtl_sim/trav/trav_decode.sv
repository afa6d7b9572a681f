// trav_decode: the traversal unit's node decode (trav_unit.sv). From a quantized AABB node of the struct layout
// (hw::qnode_bytes: origin 3 x int32 at bytes 0-11, exponents 3 x int8 at 12-14, the child count at 15, then the
// six planes' N offsets of one byte each) and the ray's origin (grid.F, signed) it forms the box unit's inputs:
// per axis the node origin relative to the ray (base, A + 1 bits) and the offsets' shift (sh), the offsets (q)
// and the child count. Its own module so that synthesis reports the decode's area apart (bench/rtl_trav_area.sh).
module trav_decode #(
    parameter int N   = 4,
    parameter int K   = 8,   // child offset bits (<= 8)
    parameter int A   = 39,
    parameter int F   = 8,
    parameter int SHW = 6,
    parameter int MDW = 8 * 56,
    localparam int CW = $clog2(N + 1)
) (
    /* verilator lint_off UNUSEDSIGNAL */  // the node's child references and any bytes past it
    input  logic [      MDW-1:0] node,
    /* verilator lint_on UNUSEDSIGNAL */
    input  logic [      3*A-1:0] org,    // the ray's origin, axis a at [a*A +: A]
    output logic [  3*(A+1)-1:0] base,
    output logic [    3*SHW-1:0] sh,
    output logic [    6*N*K-1:0] q,
    output logic [       CW-1:0] count
);
  always_comb begin
    for (int a = 0; a < 3; a++) begin
      /* verilator lint_off UNUSEDSIGNAL */  // base fits A + 1 bits (the unit's contract)
      logic signed [63:0] no, b;
      /* verilator lint_on UNUSEDSIGNAL */
      logic signed [7:0] ex;
      no = 64'($signed(node[32*a+:32]));
      ex = $signed(node[8*(12+a)+:8]);
      b = (no <<< F) - 64'($signed(org[A*a+:A]));
      base[(A+1)*a+:(A+1)] = b[A:0];
      sh[SHW*a+:SHW] = SHW'(32'(ex) + F);
    end
    for (int r = 0; r < 6; r++)
      for (int i = 0; i < N; i++) q[(r*N+i)*K+:K] = node[8*(16+r*N+i)+:K];
    count = CW'(node[8*15+:8]);
  end
endmodule
