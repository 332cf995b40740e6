/* Hand-written C reference for a non-polynomial chain: the FPU arrangement (m = 3, omega = 50,
   h*omega = 2*pi/3, method B, two-step form) with soft Toda springs V(y) = e^y - 1 - y on the
   FPU's spring elongations y_k and an on-site 1 - cos(x_{0,i}) on the slow coordinates:

     U(x) = sum_k (exp(y_k) - 1 - y_k) + sum_i (1 - cos x_{0,i}).

   Straight-line code, energies streamed as in fpu_limit.c's scalar-tracked (max/min of H_omega,
   H_slow and H at every step). Usage: toda_limit NSTEPS. Prints ns per step. */
#include <math.h>
#include <stdio.h>
#include <stdlib.h>
#include <time.h>
static double now(void){struct timespec t;clock_gettime(CLOCK_MONOTONIC,&t);return t.tv_sec+1e-9*t.tv_nsec;}
int main(int argc,char**argv){
 if(argc<2){fprintf(stderr,"usage: toda_limit NSTEPS\n");return 2;}
 long N=atol(argv[1]);
 double omega=50,h=(2*M_PI/3)/omega,s3=sin(h*omega)/(h*omega),c3=2*cos(h*omega);
 double hh=h*h,k3=hh*s3,i2h=1/(2*h),i2hs=1/(2*h*s3),w2=omega*omega;
 /* start: q1 = cos q0 + h sinc p0 + h^2/2 psi g(q0) */
 double q[6]={1,0,0,1/omega,0,0},p[6]={1,0,0,1,0,0},g[6],qp[6];
 {double e0=q[0]-q[3],e1=q[1]-q[4]-q[0]-q[3],e2=q[2]-q[5]-q[1]-q[4],e3=q[2]+q[5];
  double d0=exp(e0)-1,d1=exp(e1)-1,d2=exp(e2)-1,d3=exp(e3)-1;
  g[0]=-(d0-d1)-sin(q[0]);g[1]=-(d1-d2)-sin(q[1]);g[2]=-(d2+d3)-sin(q[2]);
  g[3]=d0+d1;g[4]=d1+d2;g[5]=d2-d3;
  for(int i=0;i<3;i++) qp[i]=q[i]+h*p[i]+0.5*hh*g[i];
  for(int i=3;i<6;i++) qp[i]=cos(h*omega)*q[i]+h*s3*p[i]+0.5*hh*s3*g[i];}
 double a0m=q[0],a1m=q[1],a2m=q[2],b0m=q[3],b1m=q[4],b2m=q[5];
 double a0=qp[0],a1=qp[1],a2=qp[2],b0=qp[3],b1=qp[4],b2=qp[5];
 double mx[3]={-1e300,-1e300,-1e300},mn[3]={1e300,1e300,1e300};
 double t=now();
 for(long k=0;k<N;k++){
  double e0=a0-b0,e1=a1-b1-a0-b0,e2=a2-b2-a1-b1,e3=a2+b2;
  double x0=exp(e0),x1=exp(e1),x2=exp(e2),x3=exp(e3);
  double d0=x0-1,d1=x1-1,d2=x2-1,d3=x3-1;
  double n0=2*a0-a0m+hh*(-(d0-d1)-sin(a0)), n1=2*a1-a1m+hh*(-(d1-d2)-sin(a1)), n2=2*a2-a2m+hh*(-(d2+d3)-sin(a2));
  double m0=c3*b0-b0m+k3*(d0+d1), m1=c3*b1-b1m+k3*(d1+d2), m2=c3*b2-b2m+k3*(d2-d3);
  double p0=(n0-a0m)*i2h,p1=(n1-a1m)*i2h,p2=(n2-a2m)*i2h,p3=(m0-b0m)*i2hs,p4=(m1-b1m)*i2hs,p5=(m2-b2m)*i2hs;
  double U=(d0-e0)+(d1-e1)+(d2-e2)+(d3-e3)+(1-cos(a0))+(1-cos(a1))+(1-cos(a2));
  double Hw=0.5*(p3*p3+p4*p4+p5*p5+w2*(b0*b0+b1*b1+b2*b2)), Hs=0.5*(p0*p0+p1*p1+p2*p2)+U, H=Hw+Hs;
  mx[0]=mx[0]>Hw?mx[0]:Hw; mn[0]=mn[0]<Hw?mn[0]:Hw; mx[1]=mx[1]>Hs?mx[1]:Hs; mn[1]=mn[1]<Hs?mn[1]:Hs;
  mx[2]=mx[2]>H?mx[2]:H; mn[2]=mn[2]<H?mn[2]:H;
  a0m=a0;a1m=a1;a2m=a2;b0m=b0;b1m=b1;b2m=b2; a0=n0;a1=n1;a2=n2;b0=m0;b1=m1;b2=m2;
 }
 double dt=now()-t; printf("%.4f\n",dt/N*1e9); fprintf(stderr,"check %g %g %g\n",a0,mx[0]-mn[0],mx[2]-mn[2]); return 0;
}
